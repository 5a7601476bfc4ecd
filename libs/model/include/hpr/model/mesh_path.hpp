#pragma once
/// \file
/// Where a URDF's mesh file is: `package://NAME/PATH`, `package:///NAME/PATH` (three slashes, as some
/// published models write it), `file://PATH`, an absolute path or one relative to the URDF, looked up
/// the way robot repositories are laid out as published:
///
///  1. `package://NAME/...`: the folder whose `package.xml` declares `<name>NAME</name>`, among the
///     URDF's ancestors and in the search folders (and their subfolders, three levels down), whatever
///     that folder is called (a `git clone` into another name);
///  2. a folder called NAME among the URDF's ancestors or in a search folder (no manifest);
///  3. the path inside the package taken from each ancestor of the URDF up to the repository root
///     (the folder holding `.git`; meshes at the root while the URDF sits in `urdf/`), then from
///     each search folder.
///
/// A mesh found nowhere is an error that names every place tried and how to add a folder.

#include <filesystem>
#include <string>
#include <vector>

namespace hpr::model {

/// `configured` (robot.mesh_search_paths, --mesh-path), then the folders of HPR_MESH_PATH and
/// ROS_PACKAGE_PATH (colon-separated).
[[nodiscard]] std::vector<std::filesystem::path> mesh_search_dirs(const std::vector<std::string>& configured);

/// The package name a `package.xml` declares ("" when `manifest` is not a readable one).
[[nodiscard]] std::string package_name(const std::filesystem::path& manifest);

/// The file `uri` names, for the URDF `urdf_path` (link `link`, for the message); throws
/// ModelError naming the URDF, the link, the URI, every place tried and the ways to add a folder.
[[nodiscard]] std::string resolve_mesh(const std::string& uri, const std::string& urdf_path, const std::string& link,
                                       const std::vector<std::filesystem::path>& search);

}  // namespace hpr::model
