// Mesh lookup on the layouts robot repositories use as published (hpr/model/mesh_path.hpp): a
// package cloned into a folder of another name (found by its package.xml), package:/// with three
// slashes, meshes at the repository root with no manifest, a URDF outside its package found through
// a search folder, and the error for a mesh that is nowhere.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "hpr/model/mesh_path.hpp"
#include "hpr/model/urdf.hpp"
#include "process_group.hpp"

namespace {

namespace fs = std::filesystem;
using hpr::model::ModelError;

std::string layout(const std::string& name) { return hpr::test::source_dir() + "/tests/unit/model/urdf/layouts/" + name; }

std::string base_mesh(const std::string& urdf, const hpr::model::UrdfOptions& options = {}) {
  const auto d = hpr::model::load_urdf(layout(urdf), options);
  return d.find_link("base")->collisions.at(0).mesh;
}

TEST(MeshPath, ThePackageIsTheFolderWhosePackageXmlNamesItWhateverTheFolderIsCalled) {
  EXPECT_EQ(hpr::model::package_name(layout("walker-main/package.xml")), "walker_description");
  EXPECT_EQ(hpr::model::package_name(layout("walker-main/urdf/walker.urdf")), "") << "not a manifest";
  EXPECT_TRUE(fs::equivalent(base_mesh("walker-main/urdf/walker.urdf"), layout("walker-main/meshes/box.stl")));
}

TEST(MeshPath, ThreeSlashPackageUrisResolveLikeTwo) {
  EXPECT_TRUE(fs::equivalent(base_mesh("walker-main/urdf/walker_three_slash.urdf"), layout("walker-main/meshes/box.stl")));
}

TEST(MeshPath, WithoutAManifestTheMeshesAreLookedForUpToTheRepositoryRoot) {
  EXPECT_TRUE(fs::equivalent(base_mesh("bare_repo/urdf/bare.urdf"), layout("bare_repo/meshes/foot.stl")));
}

TEST(MeshPath, AUrdfOutsideItsPackageFindsItInASearchFolderByItsManifest) {
  EXPECT_THROW((void)base_mesh("standalone.urdf"), ModelError);
  hpr::model::UrdfOptions options;
  options.mesh_search_paths = {layout("")};  // walker-main, one level down, holds the manifest
  EXPECT_TRUE(fs::equivalent(base_mesh("standalone.urdf", options), layout("walker-main/meshes/box.stl")));
}

TEST(MeshPath, AMeshThatIsNowhereNamesEveryPlaceTriedAndTheOptionThatAddsAFolder) {
  hpr::model::UrdfOptions options;
  options.mesh_search_paths = {"/nonexistent/meshes-here"};
  try {
    (void)base_mesh("walker-main/urdf/missing.urdf", options);
    FAIL() << "no error";
  } catch (const ModelError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("missing.urdf: link 'base': mesh 'package://walker_description/meshes/no_such.stl' not found"), std::string::npos)
        << msg;
    // The package's own folder (by its manifest), a search folder, the repository's folders.
    for (const std::string& place : {fs::path(layout("walker-main/meshes/no_such.stl")).lexically_normal().string(),
                                     std::string("/nonexistent/meshes-here/walker_description/meshes/no_such.stl"),
                                     std::string("/nonexistent/meshes-here/meshes/no_such.stl")}) {
      EXPECT_NE(msg.find("\n  " + place), std::string::npos) << place << " not named in:\n" << msg;
    }
    EXPECT_EQ(msg.find(" more"), std::string::npos) << "the list is cut:\n" << msg;
    EXPECT_NE(msg.find("--mesh-path DIR"), std::string::npos) << msg;
    EXPECT_NE(msg.find("robot.mesh_search_paths"), std::string::npos) << msg;
  }
}

}  // namespace
