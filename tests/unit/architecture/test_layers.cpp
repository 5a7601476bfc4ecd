// The tree's layers (docs/ARCHITECTURE.md): every #include points to a lower layer.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "layers.hpp"
#include "scratch_dir.hpp"

namespace fs = std::filesystem;
using hpr::arch::oversized;
using hpr::arch::read_layers;
using hpr::arch::read_size_limits;
using hpr::arch::scan;
using hpr::arch::violations;

namespace {

std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += "  " + l + "\n";
  return s;
}

/// A scratch tree of files, removed at the end.
class Tree {
 public:
  void write(const std::string& path, const std::string& text) const {
    fs::create_directories((root() / path).parent_path());
    std::ofstream(root() / path) << text;
  }
  [[nodiscard]] const fs::path& root() const { return dir_.path(); }

 private:
  hpr::test::ScratchDir dir_{"layers"};
};

/// Three layers: base (a header), mid and top each with a library whose header includes what it
/// is given.
void write_layered(const Tree& t, const std::string& base_includes, const std::string& mid_includes) {
  t.write("docs/ARCHITECTURE.md", "| layer | folders |\n|---|---|\n| 0 | `base` |\n| 1 | `mid`, `side` |\n| 2 | `top` |\n");
  t.write("base/include/hpr/base/b.hpp", "#pragma once\n" + base_includes);
  t.write("mid/include/hpr/mid/m.hpp", "#pragma once\n#include \"hpr/base/b.hpp\"\n" + mid_includes);
  t.write("side/include/hpr/side/s.hpp", "#pragma once\n#include <hpr/base/b.hpp>\n");
  t.write("top/main.cpp", "#include \"hpr/mid/m.hpp\"\n#include \"local.hpp\"\n#include <vector>\nint main() {}\n");
  t.write("top/local.hpp", "#pragma once\n#include <humanoid/x_t.hpp>\n");
}

}  // namespace

TEST(Layers, ATreeThatIncludesDownwardHasNoViolation) {
  Tree t;
  write_layered(t, "", "");
  const auto layers = read_layers(t.root() / "docs/ARCHITECTURE.md");
  ASSERT_EQ(layers.size(), 4U);
  EXPECT_EQ(layers.at("side"), 1);
  const auto report = scan(t.root(), layers);
  // mid → base, side → base (angle brackets), top → mid; the quoted local header is top's own.
  EXPECT_EQ(report.edges.size(), 3U);
  EXPECT_TRUE(violations(report, layers).empty()) << joined(violations(report, layers));
}

TEST(Layers, AnUpwardIncludeIsNamedWithItsFileLineAndLayers) {
  Tree t;
  write_layered(t, "\n#include \"hpr/mid/m.hpp\"\n", "");
  const auto layers = read_layers(t.root() / "docs/ARCHITECTURE.md");
  const auto v = violations(scan(t.root(), layers), layers);
  ASSERT_FALSE(v.empty());
  EXPECT_NE(v.front().find("base/include/hpr/base/b.hpp:3: base (layer 0) includes hpr/mid/m.hpp of mid (layer 1, above)"), std::string::npos)
      << joined(v);
  // base → mid and mid → base: a cycle, named as one.
  EXPECT_NE(joined(v).find("cycle between folders: base mid"), std::string::npos) << joined(v);
}

TEST(Layers, ASidewaysIncludeOnTheSameLayerIsRefused) {
  Tree t;
  write_layered(t, "", "#include \"hpr/side/s.hpp\"\n");
  const auto layers = read_layers(t.root() / "docs/ARCHITECTURE.md");
  const auto v = violations(scan(t.root(), layers), layers);
  ASSERT_EQ(v.size(), 1U) << joined(v);
  EXPECT_NE(v[0].find("mid (layer 1) includes hpr/side/s.hpp of side (layer 1, the same)"), std::string::npos) << v[0];
}

TEST(Layers, AFolderOutsideTheTableAndATableFolderMissingAreReported) {
  Tree t;
  write_layered(t, "", "");
  t.write("stray/x.cpp", "int x;\n");
  fs::remove_all(t.root() / "side");
  const auto layers = read_layers(t.root() / "docs/ARCHITECTURE.md");
  const auto v = joined(violations(scan(t.root(), layers), layers));
  EXPECT_NE(v.find("stray/x.cpp: in no folder of the layer table"), std::string::npos) << v;
  EXPECT_NE(v.find("side: a folder of the layer table that the tree does not have"), std::string::npos) << v;
}

TEST(Layers, TheMostSpecificFolderOwnsAFile) {
  const std::map<std::string, int> layers{{"sim/core", 6}, {"sim/engines", 8}, {"sim", 9}};
  EXPECT_EQ(hpr::arch::folder_of("sim/core/src/simulator.cpp", layers), "sim/core");
  EXPECT_EQ(hpr::arch::folder_of("sim/engines/src/engines.cpp", layers), "sim/engines");
  EXPECT_EQ(hpr::arch::folder_of("sim/other.cpp", layers), "sim");
  EXPECT_EQ(hpr::arch::folder_of("simulation/x.cpp", layers), "");
}

// The tree itself keeps to docs/ARCHITECTURE.md.
TEST(Layers, TheTreeIncludesOnlyDownward) {
  const fs::path root = HPR_TEST_SOURCE_DIR;
  const auto layers = read_layers(root / "docs/ARCHITECTURE.md");
  const auto report = scan(root, layers);
  // The scan found the stack's includes: a component's of the libraries, a process's of the graph.
  const auto has_edge = [&](const std::string& from, const std::string& to) {
    return std::any_of(report.edges.begin(), report.edges.end(), [&](const auto& e) { return e.from == from && e.to == to; });
  };
  EXPECT_TRUE(has_edge("wbc", "libs/qp"));
  EXPECT_TRUE(has_edge("processes", "graph"));
  EXPECT_TRUE(has_edge("sim/engines", "sim/mujoco"));
  const auto v = violations(report, layers);
  EXPECT_TRUE(v.empty()) << "the tree breaks the layer order of docs/ARCHITECTURE.md:\n" << joined(v);
}

namespace {

TEST(Sizes, AFileLongerThanItsFoldersLimitIsNamedWithItsLength) {
  Tree t;
  t.write("docs/ARCHITECTURE.md", "| folder | lines |\n|---|---|\n| `small` | 3 |\n| `gone` | 10 |\n");
  t.write("small/src/short.cpp", "a\nb\nc\n");
  t.write("small/include/long.hpp", "a\nb\nc\nd\n");
  t.write("large/any.cpp", "a\nb\nc\nd\ne\n");  // no limit
  const auto limits = read_size_limits(t.root() / "docs/ARCHITECTURE.md");
  ASSERT_EQ(limits.size(), 2U);
  EXPECT_EQ(limits.at("small"), 3);
  const auto v = oversized(t.root(), limits);
  ASSERT_EQ(v.size(), 2U) << joined(v);
  EXPECT_EQ(v[0], "gone: in the size table, not in the tree");
  EXPECT_EQ(v[1], "small/include/long.hpp: 4 lines, at most 3");
}

// The tree keeps to the size table of docs/ARCHITECTURE.md (the node runtime in parts).
TEST(Sizes, TheTreeKeepsToTheSizeTable) {
  const fs::path root = HPR_TEST_SOURCE_DIR;
  const auto limits = read_size_limits(root / "docs/ARCHITECTURE.md");
  ASSERT_TRUE(limits.count("libs/node")) << "docs/ARCHITECTURE.md has no size row for libs/node";
  const auto v = oversized(root, limits);
  EXPECT_TRUE(v.empty()) << "files longer than docs/ARCHITECTURE.md allows:\n" << joined(v);
}

}  // namespace
