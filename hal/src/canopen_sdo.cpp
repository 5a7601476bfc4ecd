#include "hpr/hal/canopen_sdo.hpp"

#include <fmt/format.h>

#include <initializer_list>

namespace hpr::hal::canopen {

namespace {

constexpr std::uint32_t kPdoDisabled = 0x80000000U;  ///< COB-ID bit 31: the PDO does not exist
constexpr std::uint32_t kSynchronous = 1;            ///< transmission type: every SYNC

/// A mapping entry: object index, subindex and length in bits (CiA 301 §7.5.2.36).
constexpr std::uint32_t mapping(std::uint16_t index, std::uint8_t sub, int bits) {
  return (static_cast<std::uint32_t>(index) << 16) | (static_cast<std::uint32_t>(sub) << 8) | static_cast<std::uint32_t>(bits);
}

struct Mapped {
  std::uint16_t index;
  int bits;
  const char* name;
};

/// The writes of one PDO: communication parameter `comm` (COB-ID `cob`), mapping parameter `map`.
void pdo(std::vector<SdoWrite>& w, const char* pdo_name, std::uint16_t comm, std::uint16_t map, std::uint32_t cob,
         std::initializer_list<Mapped> objects) {
  w.push_back({{comm, 1}, kPdoDisabled | cob, 4, fmt::format("{} disabled while it is mapped", pdo_name)});
  w.push_back({{comm, 2}, kSynchronous, 1, fmt::format("{} transmission type: synchronous", pdo_name)});
  w.push_back({{map, 0}, 0, 1, fmt::format("{} mapping cleared", pdo_name)});
  std::uint8_t sub = 1;
  for (const Mapped& m : objects) {
    w.push_back({{map, sub}, mapping(m.index, 0, m.bits), 4, fmt::format("{} mapping {}: {}", pdo_name, sub, m.name)});
    ++sub;
  }
  w.push_back({{map, 0}, static_cast<std::uint32_t>(sub - 1), 1, fmt::format("{} mapping count", pdo_name)});
  w.push_back({{comm, 1}, cob, 4, fmt::format("{} enabled", pdo_name)});
}

}  // namespace

std::vector<SdoWrite> cst_configuration(int node, int heartbeat_ms) {
  const auto n = static_cast<std::uint32_t>(node);
  std::vector<SdoWrite> w;
  pdo(w, "RPDO1", 0x1400, 0x1600, kRpdo1 + n, {{kControlword, 16, "controlword"}, {kTargetTorque, 16, "target torque"}});
  pdo(w, "TPDO1", 0x1800, 0x1A00, kTpdo1 + n,
      {{kStatusword, 16, "statusword"}, {kTorqueActual, 16, "torque actual value"}, {kPositionActual, 32, "position actual value"}});
  pdo(w, "TPDO2", 0x1801, 0x1A01, kTpdo2 + n, {{kVelocityActual, 32, "velocity actual value"}});
  w.push_back({{kModesOfOperation, 0}, static_cast<std::uint32_t>(kModeCyclicSyncTorque), 1, "mode of operation: cyclic synchronous torque"});
  w.push_back({{0x1017, 0}, static_cast<std::uint32_t>(heartbeat_ms), 2, "heartbeat producer time [ms]"});
  return w;
}

SdoSequence::SdoSequence(int node, std::vector<SdoWrite> writes, double timeout_s)
    : node_(node), writes_(std::move(writes)), timeout_(timeout_s) {}

std::string SdoSequence::describe(const SdoWrite& w) const {
  return fmt::format("node {}: SDO write 0x{:04X}:{:02X} = 0x{:0{}X} ({})", node_, w.address.index, w.address.subindex, w.value,
                     2 * w.size, w.what);
}

std::optional<CanFrame> SdoSequence::poll(double t) {
  if (failed() || next_ >= writes_.size()) return std::nullopt;
  if (sent_at_) {
    if (t - *sent_at_ > timeout_) error_ = fmt::format("{}: no answer within {:.3f} s", describe(writes_[next_]), timeout_);
    return std::nullopt;
  }
  sent_at_ = t;
  const SdoWrite& w = writes_[next_];
  return sdo_download(node_, w.address, w.value, w.size);
}

void SdoSequence::on_frame(const CanFrame& f, double) {
  if (failed() || next_ >= writes_.size() || !sent_at_) return;
  if (f.id != kSdoTxBase + static_cast<std::uint32_t>(node_)) return;
  const auto m = decode_sdo(f, node_);
  const SdoWrite& w = writes_[next_];
  if (!m) {
    error_ = fmt::format("{}: the answer is no expedited SDO frame", describe(w));
    return;
  }
  if (m->address.index != w.address.index || m->address.subindex != w.address.subindex) {
    error_ = fmt::format("{}: the answer is about 0x{:04X}:{:02X}", describe(w), m->address.index, m->address.subindex);
    return;
  }
  if (m->kind == SdoMessage::Kind::kAbort) {
    error_ = fmt::format("{} refused: abort 0x{:08X} ({})", describe(w), m->value, sdo_abort_meaning(m->value));
    return;
  }
  if (m->kind != SdoMessage::Kind::kDownloadDone) {
    error_ = fmt::format("{}: the answer is not a download confirmation", describe(w));
    return;
  }
  ++next_;
  sent_at_.reset();
}

SdoServer::SdoServer(int node, const ObjectDictionary& od) : node_(node), od_(&od) {
  for (const auto& [address, e] : od.entries()) {
    if (const auto v = od.value(address.first, address.second, node)) values_[address] = *v;
  }
}

std::optional<std::uint64_t> SdoServer::value(std::uint16_t index, std::uint8_t subindex) const {
  const auto it = values_.find({index, subindex});
  if (it == values_.end()) return std::nullopt;
  return it->second;
}

std::optional<CanFrame> SdoServer::on_frame(const CanFrame& f) {
  if (f.id != kSdoRxBase + static_cast<std::uint32_t>(node_)) return std::nullopt;
  const auto m = decode_sdo(f, node_);
  if (!m) {
    const SdoAddress a{static_cast<std::uint16_t>(f.data[1] | (f.data[2] << 8)), f.data[3]};
    return sdo_abort(node_, a, kAbortCommandSpecifier);
  }
  const SdoAddress a = m->address;
  const OdEntry* e = od_->find(a.index, a.subindex);
  if (e == nullptr) {
    const bool object_exists = od_->find(a.index, 0) != nullptr;
    return sdo_abort(node_, a, object_exists ? kAbortNoSubindex : kAbortNoObject);
  }
  const int size = size_of(e->type);
  if (m->kind == SdoMessage::Kind::kUploadRequest) {
    if (!e->readable()) return sdo_abort(node_, a, kAbortWriteOnly);
    if (size == 0 || size > 4) return sdo_abort(node_, a, kAbortUnsupportedAccess);  // needs a segmented transfer
    return sdo_upload_data(node_, a, static_cast<std::uint32_t>(values_[{a.index, a.subindex}]), size);
  }
  if (m->kind != SdoMessage::Kind::kDownloadRequest) return sdo_abort(node_, a, kAbortCommandSpecifier);
  if (!e->writable()) return sdo_abort(node_, a, kAbortReadOnly);
  if (m->size != 0 && m->size != size) return sdo_abort(node_, a, kAbortLengthMismatch);
  // A mapping entry (0x1600-0x17FF, 0x1A00-0x1BFF, sub-index 1 on) must name an object that may be
  // mapped, with its own length.
  const bool mapping_entry = ((a.index >= 0x1600 && a.index <= 0x17FF) || (a.index >= 0x1A00 && a.index <= 0x1BFF)) && a.subindex >= 1;
  if (mapping_entry && m->value != 0) {
    const auto obj = static_cast<std::uint16_t>(m->value >> 16);
    const auto sub = static_cast<std::uint8_t>((m->value >> 8) & 0xFF);
    const OdEntry* mapped = od_->find(obj, sub);
    if (mapped == nullptr) return sdo_abort(node_, a, kAbortNoObject);
    if (!mapped->pdo_mappable || static_cast<int>(m->value & 0xFF) != 8 * size_of(mapped->type)) {
      return sdo_abort(node_, a, 0x06040041);  // object cannot be mapped to the PDO
    }
  }
  values_[{a.index, a.subindex}] = m->value;
  return sdo_download_done(node_, a);
}

}  // namespace hpr::hal::canopen
