// The seed corpus of fuzz_lcm_decode: one message of each LCM type (random content, 27 joints), as
// the target reads it (one byte choosing the type, then the encoded message), in a file named after
// the type's channel. A seed that no longer decodes (its type changed) starts the fuzzer from
// nothing for that type, so the default test run checks them.
//
//   fuzz_lcm_seeds --write tests/fuzz/corpus/lcm_decode    (after a change to lcmtypes/)
//   fuzz_lcm_seeds --check tests/fuzz/corpus/lcm_decode    (CTest: FuzzSeeds.lcm_decode)
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "all_types.hpp"

int main(int argc, char** argv) {
  if (argc != 3 || (std::strcmp(argv[1], "--write") != 0 && std::strcmp(argv[1], "--check") != 0)) {
    std::cerr << "usage: fuzz_lcm_seeds --write|--check DIR\n";
    return 2;
  }
  const bool write = std::strcmp(argv[1], "--write") == 0;
  const std::string dir = argv[2];
  int index = 0, failed = 0;
  hpr::test::for_each_type([&]<class Msg>(const char* name) {
    const std::string path = dir + "/" + name;
    const auto selector = static_cast<std::uint8_t>(index++);
    if (write) {
      hpr::test::Filler filler(static_cast<unsigned>(selector) + 1);
      Msg m{};
      filler.fill(m);
      std::vector<std::uint8_t> bytes = hpr::test::encode(m);
      bytes.insert(bytes.begin(), selector);
      std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
      return;
    }
    std::ifstream in(path, std::ios::binary);
    const std::vector<std::uint8_t> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    Msg m{};
    if (bytes.empty() || bytes[0] != selector) {
      std::cerr << path << ": missing, or its first byte is not " << int{selector} << " (the target's index of " << name << ")\n";
      ++failed;
    } else if (m.decode(bytes.data() + 1, 0, static_cast<int>(bytes.size() - 1)) != static_cast<int>(bytes.size() - 1)) {
      std::cerr << path << ": does not decode as " << Msg::getTypeName() << " (the type changed)\n";
      ++failed;
    }
  });
  if (failed != 0) std::cerr << failed << " stale seeds: fuzz_lcm_seeds --write " << dir << "\n";
  return failed == 0 ? 0 : 1;
}
