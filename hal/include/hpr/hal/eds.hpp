#pragma once
/// \file
/// A CANopen drive's object dictionary from its electronic data sheet (EDS) or device
/// configuration file (DCF), CiA 306: an INI file with one section per object ([6040]) and per
/// sub-object ([1A00sub1]), each with ParameterName, ObjectType, DataType, AccessType, DefaultValue
/// (or a DCF's ParameterValue) and PDOMapping. Values may be decimal, hexadecimal (0x...) or octal
/// (a leading 0), and may add the node id ($NODEID+0x180). A file that is not one is refused with
/// its name, line, section, key and value.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "hpr/common/config.hpp"

namespace hpr::hal::canopen {

/// CiA 301 data types (table 44) the drive profile uses.
enum class DataType : std::uint16_t {
  kBoolean = 0x0001,
  kInteger8 = 0x0002,
  kInteger16 = 0x0003,
  kInteger32 = 0x0004,
  kUnsigned8 = 0x0005,
  kUnsigned16 = 0x0006,
  kUnsigned32 = 0x0007,
  kReal32 = 0x0008,
  kVisibleString = 0x0009,
  kOctetString = 0x000A,
  kUnicodeString = 0x000B,
  kDomain = 0x000F,
  kInteger24 = 0x0010,
  kReal64 = 0x0011,
  kInteger64 = 0x0015,
  kUnsigned24 = 0x0016,
  kUnsigned64 = 0x001B,
};
/// Bytes of a fixed-size type (0 for strings and domains).
int size_of(DataType t);

enum class Access { kReadOnly, kWriteOnly, kReadWrite, kReadWriteOnRead, kReadWriteOnWrite, kConst };

/// One object or sub-object that holds a value (ObjectType VAR).
struct OdEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::string name;
  DataType type = DataType::kUnsigned32;
  Access access = Access::kReadOnly;
  bool pdo_mappable = false;
  std::string value;  ///< DefaultValue (or a DCF's ParameterValue) as written, maybe with $NODEID
  int line = 0;       ///< where its section starts
  [[nodiscard]] bool readable() const { return access != Access::kWriteOnly; }
  [[nodiscard]] bool writable() const { return access != Access::kReadOnly && access != Access::kConst; }
};

class ObjectDictionary {
 public:
  /// Reads an EDS or DCF file; throws ConfigError naming the file, line, section, key and value.
  static ObjectDictionary load(const std::string& path);
  /// The same from text; `name` stands for the file in messages.
  static ObjectDictionary parse(std::string_view text, const std::string& name);

  [[nodiscard]] const OdEntry* find(std::uint16_t index, std::uint8_t subindex = 0) const;
  /// The entry's value for node `node` ($NODEID replaced), as an unsigned integer of its size (a
  /// negative value of a signed type in two's complement); nullopt without an entry or a value, or
  /// for a string or domain.
  [[nodiscard]] std::optional<std::uint64_t> value(std::uint16_t index, std::uint8_t subindex, int node) const;
  /// The entry, or a ConfigError that names the file and the object the hal needs.
  [[nodiscard]] const OdEntry& require(std::uint16_t index, std::uint8_t subindex, std::string_view why) const;
  [[nodiscard]] std::size_t size() const { return entries_.size(); }
  /// Every entry, by (index, subindex).
  [[nodiscard]] const std::map<std::pair<std::uint16_t, std::uint8_t>, OdEntry>& entries() const { return entries_; }
  [[nodiscard]] const std::string& source() const { return source_; }

 private:
  std::string source_;
  std::map<std::pair<std::uint16_t, std::uint8_t>, OdEntry> entries_;
};

/// An EDS number: decimal, 0x hexadecimal or octal (a leading 0), optionally "$NODEID+" before it
/// (or after it: "0x180+$NODEID"); nullopt when it is not one.
std::optional<std::int64_t> parse_eds_number(std::string_view text, int node);

}  // namespace hpr::hal::canopen
