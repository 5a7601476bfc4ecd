#include "hpr/hal/eds.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

namespace hpr::hal::canopen {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front())) != 0) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back())) != 0) s.remove_suffix(1);
  return s;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

/// An unsigned number in `base` spanning all of `s`.
std::optional<std::int64_t> whole(std::string_view s, int base) {
  if (s.empty()) return std::nullopt;
  std::int64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v, base);
  if (ec != std::errc() || end != s.data() + s.size() || v < 0) return std::nullopt;
  return v;
}

std::optional<std::int64_t> plain_number(std::string_view s) {
  s = trim(s);
  bool negative = false;
  if (!s.empty() && (s.front() == '-' || s.front() == '+')) {
    negative = s.front() == '-';
    s.remove_prefix(1);
  }
  std::optional<std::int64_t> v;
  if (s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) {
    v = whole(s.substr(2), 16);
  } else if (s.size() > 1 && s[0] == '0') {
    v = whole(s.substr(1), 8);
  } else {
    v = whole(s, 10);
  }
  if (!v) return std::nullopt;
  return negative ? -*v : *v;
}

/// One key of a section, where it was written.
struct Key {
  std::string value;
  int line = 0;
};
struct Section {
  std::string name;  ///< as written
  int line = 0;
  std::map<std::string, Key> keys;  ///< by lower-case key
};

[[noreturn]] void fail(const std::string& file, int line, const std::string& what) {
  throw ConfigError(fmt::format("{}:{}: {}", file, line, what));
}

/// An object section's (index, subindex): "6040" or "1A00sub1" (any case); nullopt for another section.
std::optional<std::pair<std::uint16_t, std::uint8_t>> object_of(std::string_view name, bool& is_sub) {
  const std::string n = lower(name);
  if (n.size() < 4) return std::nullopt;
  const auto index = whole(std::string_view(n).substr(0, 4), 16);
  if (!index) return std::nullopt;
  if (n.size() == 4) {
    is_sub = false;
    return std::make_pair(static_cast<std::uint16_t>(*index), std::uint8_t{0});
  }
  if (n.compare(4, 3, "sub") != 0 || n.size() == 7) return std::nullopt;
  const auto sub = whole(std::string_view(n).substr(7), 16);
  if (!sub || *sub > 0xFF) return std::nullopt;
  is_sub = true;
  return std::make_pair(static_cast<std::uint16_t>(*index), static_cast<std::uint8_t>(*sub));
}

bool known_type(std::int64_t t) {
  switch (t) {
    case 0x01: case 0x02: case 0x03: case 0x04: case 0x05: case 0x06: case 0x07: case 0x08: case 0x09:
    case 0x0A: case 0x0B: case 0x0F: case 0x10: case 0x11: case 0x15: case 0x16: case 0x1B: return true;
    default: return false;
  }
}

std::optional<Access> access_of(std::string_view s) {
  const std::string a = lower(trim(s));
  if (a == "ro") return Access::kReadOnly;
  if (a == "wo") return Access::kWriteOnly;
  if (a == "rw") return Access::kReadWrite;
  if (a == "rwr") return Access::kReadWriteOnRead;
  if (a == "rww") return Access::kReadWriteOnWrite;
  if (a == "const") return Access::kConst;
  return std::nullopt;
}

bool numeric(DataType t) { return size_of(t) > 0; }
bool real(DataType t) { return t == DataType::kReal32 || t == DataType::kReal64; }

}  // namespace

int size_of(DataType t) {
  switch (t) {
    case DataType::kBoolean: case DataType::kInteger8: case DataType::kUnsigned8: return 1;
    case DataType::kInteger16: case DataType::kUnsigned16: return 2;
    case DataType::kInteger24: case DataType::kUnsigned24: return 3;
    case DataType::kInteger32: case DataType::kUnsigned32: case DataType::kReal32: return 4;
    case DataType::kReal64: case DataType::kInteger64: case DataType::kUnsigned64: return 8;
    case DataType::kVisibleString: case DataType::kOctetString: case DataType::kUnicodeString: case DataType::kDomain: return 0;
  }
  return 0;
}

std::optional<std::int64_t> parse_eds_number(std::string_view text, int node) {
  text = trim(text);
  if (text.empty()) return std::nullopt;
  std::int64_t sum = 0;
  size_t start = 0;
  // Terms joined by '+' (a leading sign belongs to its number).
  while (start <= text.size()) {
    size_t plus = text.find('+', start == 0 && !text.empty() && text[0] == '+' ? 1 : start);
    if (plus == std::string_view::npos) plus = text.size();
    const std::string_view term = trim(text.substr(start, plus - start));
    if (lower(term) == "$nodeid") {
      sum += node;
    } else {
      const auto v = plain_number(term);
      if (!v) return std::nullopt;
      sum += *v;
    }
    start = plus + 1;
    if (plus == text.size()) break;
  }
  return sum;
}

ObjectDictionary ObjectDictionary::load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(fmt::format("{}: cannot read the EDS/DCF file: {}", path, std::strerror(errno)));
  std::stringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), path);
}

ObjectDictionary ObjectDictionary::parse(std::string_view text, const std::string& name) {
  ObjectDictionary od;
  od.source_ = name;
  // The INI structure.
  std::vector<Section> sections;
  std::map<std::string, int> seen;  // lower-case section name -> line
  int line_no = 0;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = trim(text.substr(pos, nl - pos));
    ++line_no;
    pos = nl + 1;
    if (line.empty() || line.front() == ';' || line.front() == '#') {
      if (nl == text.size()) break;
      continue;
    }
    if (line.front() == '[') {
      if (line.back() != ']' || line.size() < 3) fail(name, line_no, fmt::format("'{}': a section header is [NAME]", line));
      Section s;
      s.name = std::string(trim(line.substr(1, line.size() - 2)));
      s.line = line_no;
      const auto [it, fresh] = seen.emplace(lower(s.name), line_no);
      if (!fresh) fail(name, line_no, fmt::format("[{}] again (first at line {})", s.name, it->second));
      sections.push_back(std::move(s));
    } else {
      const size_t eq = line.find('=');
      if (eq == std::string_view::npos) fail(name, line_no, fmt::format("'{}': expected KEY=VALUE or [SECTION]", line));
      if (sections.empty()) fail(name, line_no, fmt::format("'{}' before any [SECTION]", line));
      const std::string key = lower(trim(line.substr(0, eq)));
      if (key.empty()) fail(name, line_no, fmt::format("[{}] '{}': a key before the '='", sections.back().name, line));
      const auto [it, fresh] = sections.back().keys.emplace(key, Key{std::string(trim(line.substr(eq + 1))), line_no});
      if (!fresh) {
        fail(name, line_no, fmt::format("[{}] {} again (first at line {})", sections.back().name, trim(line.substr(0, eq)), it->second.line));
      }
    }
    if (nl == text.size()) break;
  }
  // The objects.
  for (const Section& s : sections) {
    bool is_sub = false;
    const auto address = object_of(s.name, is_sub);
    if (!address) continue;  // FileInfo, DeviceInfo, the object lists, comments ...
    const auto key = [&](const char* k) -> const Key* {
      const auto it = s.keys.find(lower(k));
      return it == s.keys.end() ? nullptr : &it->second;
    };
    const auto bad = [&](const char* k, const Key& v, const std::string& expected) {
      fail(name, v.line, fmt::format("[{}] {} = {}: {}", s.name, k, v.value, expected));
    };
    std::int64_t object_type = 0x7;
    if (const Key* k = key("ObjectType")) {
      const auto v = parse_eds_number(k->value, 0);
      if (!v || (*v != 0x2 && *v != 0x5 && *v != 0x6 && *v != 0x7 && *v != 0x8 && *v != 0x9)) {
        bad("ObjectType", *k, "expected 0x2 (DOMAIN), 0x5 (DEFTYPE), 0x6 (DEFSTRUCT), 0x7 (VAR), 0x8 (ARRAY) or 0x9 (RECORD)");
      }
      object_type = *v;
    }
    if (object_type == 0x8 || object_type == 0x9) {
      // An array or record: its sub-objects are sections of their own; SubNumber counts them.
      const Key* n = key("SubNumber");
      if (n != nullptr) {
        const auto v = parse_eds_number(n->value, 0);
        if (!v || *v < 1 || *v > 255) bad("SubNumber", *n, "expected the number of sub-objects, 1 to 255");
      }
      continue;
    }
    if (object_type == 0x5 || object_type == 0x6) continue;  // type definitions
    OdEntry e;
    e.index = address->first;
    e.subindex = address->second;
    e.line = s.line;
    const Key* pn = key("ParameterName");
    if (pn == nullptr) fail(name, s.line, fmt::format("[{}]: no ParameterName", s.name));
    e.name = pn->value;
    const Key* dt = key("DataType");
    if (dt == nullptr) fail(name, s.line, fmt::format("[{}] ({}): no DataType", s.name, e.name));
    const auto t = parse_eds_number(dt->value, 0);
    if (!t || !known_type(*t)) bad("DataType", *dt, "expected a CiA 301 data type (0x0001 BOOLEAN ... 0x001B UNSIGNED64)");
    e.type = static_cast<DataType>(*t);
    const Key* at = key("AccessType");
    if (at == nullptr) fail(name, s.line, fmt::format("[{}] ({}): no AccessType", s.name, e.name));
    const auto a = access_of(at->value);
    if (!a) bad("AccessType", *at, "expected ro, wo, rw, rwr, rww or const");
    e.access = *a;
    if (const Key* pm = key("PDOMapping")) {
      const auto v = parse_eds_number(pm->value, 0);
      if (!v || (*v != 0 && *v != 1)) bad("PDOMapping", *pm, "expected 0 or 1");
      e.pdo_mappable = *v == 1;
    }
    // A DCF's ParameterValue is what the device is configured with; else the EDS's default.
    const Key* val = key("ParameterValue");
    const char* val_key = "ParameterValue";
    if (val == nullptr || val->value.empty()) {
      val = key("DefaultValue");
      val_key = "DefaultValue";
    }
    if (val != nullptr && !val->value.empty()) {
      e.value = val->value;
      if (numeric(e.type)) {
        bool ok = false;
        if (real(e.type)) {
          const std::string v(trim(val->value));
          char* end = nullptr;
          (void)std::strtod(v.c_str(), &end);
          ok = end != nullptr && *end == '\0' && !v.empty();
        } else {
          ok = parse_eds_number(val->value, 1).has_value();
        }
        if (!ok) bad(val_key, *val, "expected a number (decimal, 0x hexadecimal, octal, or with $NODEID+)");
      }
    }
    od.entries_[*address] = std::move(e);
  }
  return od;
}

const OdEntry* ObjectDictionary::find(std::uint16_t index, std::uint8_t subindex) const {
  const auto it = entries_.find({index, subindex});
  return it == entries_.end() ? nullptr : &it->second;
}

const OdEntry& ObjectDictionary::require(std::uint16_t index, std::uint8_t subindex, std::string_view why) const {
  const OdEntry* e = find(index, subindex);
  if (e == nullptr) throw ConfigError(fmt::format("{}: no object 0x{:04X}:{:02X} ({})", source_, index, subindex, why));
  return *e;
}

std::optional<std::uint64_t> ObjectDictionary::value(std::uint16_t index, std::uint8_t subindex, int node) const {
  const OdEntry* e = find(index, subindex);
  if (e == nullptr || e->value.empty() || !numeric(e->type)) return std::nullopt;
  const int bytes = size_of(e->type);
  const std::uint64_t mask = bytes >= 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8 * bytes)) - 1;
  if (e->type == DataType::kReal32) return std::bit_cast<std::uint32_t>(static_cast<float>(std::strtod(e->value.c_str(), nullptr)));
  if (e->type == DataType::kReal64) return std::bit_cast<std::uint64_t>(std::strtod(e->value.c_str(), nullptr));
  const auto v = parse_eds_number(e->value, node);
  if (!v) return std::nullopt;
  return static_cast<std::uint64_t>(*v) & mask;
}

}  // namespace hpr::hal::canopen
