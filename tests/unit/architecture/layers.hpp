#pragma once
/// \file
/// The layer check of the tree (docs/ARCHITECTURE.md): the layer table read from the document, every
/// `#include` of every C++ file read from the sources, and what breaks the order; and the size
/// table, against the length of each file.
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace hpr::arch {

/// Folder (relative to the root, '/'-separated) → layer, from the document's table: each row
/// `| N | \`folder\`, \`folder\` | ... |`. Throws std::runtime_error when the document has no table.
std::map<std::string, int> read_layers(const std::filesystem::path& document);

/// One include between two folders of the table.
struct Edge {
  std::string from, to;  ///< folders
  std::string file;      ///< the including file, relative to the root
  int line = 0;
  std::string header;    ///< as written in the include
};

struct Report {
  std::vector<Edge> edges;            ///< every include from one folder into another
  std::vector<std::string> unplaced;  ///< files in no folder of the table
  std::vector<std::string> missing;   ///< folders of the table that the tree does not have
};

/// Reads every C++ file under `root` (skipping build trees, .git and node_modules) and the folder
/// each of its includes belongs to: an `hpr/...` header to the folder whose include/ holds it,
/// `humanoid/...` to lcmtypes, a quoted file beside the includer to the includer's folder.
Report scan(const std::filesystem::path& root, const std::map<std::string, int>& layers);

/// The folder of `relative_path` in `layers` (the most specific), or "" when none holds it.
std::string folder_of(const std::string& relative_path, const std::map<std::string, int>& layers);

/// What breaks the order, one line each: an edge to the same or a higher layer, a cycle between
/// folders, an unplaced file, a missing folder. Empty when the tree keeps to the table.
std::vector<std::string> violations(const Report& report, const std::map<std::string, int>& layers);

/// Folder → the most lines a C++ file under it may have, from the document's size table: each row
/// `| \`folder\` | N |`. Empty when the document has none.
std::map<std::string, int> read_size_limits(const std::filesystem::path& document);

/// The C++ files under `root` longer than their folder's limit, one line each ("path: N lines, at
/// most M"), and a folder of the table that `root` does not have.
std::vector<std::string> oversized(const std::filesystem::path& root, const std::map<std::string, int>& limits);

}  // namespace hpr::arch
