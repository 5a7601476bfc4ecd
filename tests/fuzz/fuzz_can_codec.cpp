// Fuzz target: what the hal reads from a bus. The input is a cannelloni datagram (UDP transport);
// each frame it holds, and the raw input as one frame, go through every decoder of the drive and
// sensor protocol. Decoders return nothing or finite values within the drive's limits; a reply
// that decodes encodes back to the same bits.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "hpr/hal/cannelloni.hpp"
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

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<CanFrame> frames;
  const std::string why = cannelloni_decode(std::span<const std::uint8_t>(data, size), frames);
  if (!why.empty() && !frames.empty()) std::abort();  // an error appends nothing
  for (const auto& f : frames) {
    if (f.len > 64 || (!f.fd && f.len > 8)) std::abort();
    check_frame(f);
  }
  if (size >= 5) {
    CanFrame f;
    f.id = (static_cast<std::uint32_t>(data[0]) << 8 | data[1]) & 0x7FF;
    f.len = static_cast<std::uint8_t>(std::min<std::size_t>(8, size - 2));
    std::copy(data + 2, data + 2 + f.len, f.data.begin());
    check_frame(f);
  }
  return 0;
}
