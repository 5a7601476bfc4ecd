// Fuzz target: what the hal reads from a bus. The input is a cannelloni datagram (UDP transport);
// each frame it holds, and the raw input as one frame, go through every decoder of the drive and
// sensor protocol. Decoders return nothing or finite values within the drive's limits; a reply
// that decodes encodes back to the same bits. The same frames reach a running CiA 402 master and
// device: the master's sample stays finite and it never sends a torque for a non-finite request.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "hpr/hal/cannelloni.hpp"
#include "hpr/hal/cia402.hpp"
#include "hpr/hal/mit_codec.hpp"

namespace {

using namespace hpr::hal;

void check_frame(const CanFrame& f) {
  static const MitCodec codec;
  DriveLimits l;
  if (const auto r = codec.decode_reply(f, l)) {
    if (!std::isfinite(r->p) || !std::isfinite(r->v) || !std::isfinite(r->t)) std::abort();
    if (r->p < l.p_min - 1e-9 || r->p > l.p_max + 1e-9 || r->t < l.t_min - 1e-9 || r->t > l.t_max + 1e-9) std::abort();
    const CanFrame again = codec.encode_reply(*r, l);
    const auto r2 = codec.decode_reply(again, l);
    if (!r2 || r2->p != r->p || r2->v != r->v || r2->t != r->t || r2->fault != r->fault) std::abort();
  }
  if (const auto q = codec.decode_request(f, l)) {
    if (q->drive_id < 0 || q->drive_id > MitCodec::kMaxDriveId) std::abort();
    if (q->command) {
      const auto& c = *q->command;
      if (!std::isfinite(c.p_des) || !std::isfinite(c.v_des) || !std::isfinite(c.kp) || !std::isfinite(c.kd) ||
          !std::isfinite(c.t_ff)) {
        std::abort();
      }
    }
  }
  (void)decode_lockstep_tick(f);
  double values[4];
  if (decode_int16s(f, values, 4, 0.01)) {
    for (double v : values) {
      if (!std::isfinite(v)) std::abort();
    }
  }
}

/// A CiA 402 master and device, started and enabled; then `frames` reach both.
void check_cia402(const std::vector<CanFrame>& frames) {
  static const canopen::ObjectDictionary od = canopen::ObjectDictionary::parse(Cia402Device::default_eds(500), "fuzz.eds");
  Cia402Device device(5, od);
  Cia402Master master(5, Cia402Scaling{}, CanOpenTiming{});
  std::vector<CanFrame> to_drive, from_drive;
  double now = 0.0;
  auto tick = [&](bool enable, double torque) {
    now += 1e-3;
    to_drive.clear();
    from_drive.clear();
    master.tick(now, enable, torque, to_drive);
    to_drive.push_back(canopen::sync_frame());
    for (const CanFrame& f : to_drive) device.on_frame(f, now, from_drive);
    device.periodic(now, 0.02, from_drive);
    for (const CanFrame& f : from_drive) master.on_frame(f, now);
    master.supervise(now);
  };
  device.power_on(from_drive);
  for (int k = 0; k < 200 && !master.enabled(); ++k) tick(true, 0.0);
  if (!master.enabled()) std::abort();  // the drive starts the same way every time
  for (const CanFrame& f : frames) {
    (void)master.on_frame(f, now);
    from_drive.clear();
    device.on_frame(f, now, from_drive);
    for (const CanFrame& g : from_drive) (void)master.on_frame(g, now);
  }
  if (!std::isfinite(master.position()) || !std::isfinite(master.velocity()) || !std::isfinite(master.torque())) std::abort();
  tick(true, std::nan(""));
  for (const CanFrame& f : to_drive) {
    if (f.id == canopen::kRpdo1 + 5 && (f.data[2] != 0 || f.data[3] != 0)) std::abort();  // a NaN request sends no torque
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<CanFrame> frames;
  const std::string why = cannelloni_decode(std::span<const std::uint8_t>(data, size), frames);
  if (!why.empty() && !frames.empty()) std::abort();  // an error appends nothing
  for (const auto& f : frames) {
    if (f.len > 64 || (!f.fd && f.len > 8)) std::abort();
    check_frame(f);
  }
  check_cia402(frames);
  if (size >= 5) {
    CanFrame f;
    f.id = (static_cast<std::uint32_t>(data[0]) << 8 | data[1]) & 0x7FF;
    f.len = static_cast<std::uint8_t>(std::min<std::size_t>(8, size - 2));
    std::copy(data + 2, data + 2 + f.len, f.data.begin());
    check_frame(f);
  }
  return 0;
}
