#pragma once
/// Paths of the real test meshes (Debian's libcgal-demo data, fetched by the
/// `test_data` CTest fixture) and of the command-line program.
#include <string>

namespace t2stest {

inline std::string dataDir() { return T2S_TEST_DATA_DIR; }
/// data/meshes/<name>.off of libcgal-demo.
inline std::string cgalMesh(const std::string& name) { return dataDir() + "/meshes/" + name + ".off"; }
inline std::string sourceDir() { return T2S_SOURCE_DIR; }
inline std::string cliPath() { return T2S_CLI; }

/// The ten closed genus-0 surfaces of design.md's test data.
inline const char* const kGenus0Meshes[] = {"blob-closed", "part",   "spool",   "hand",  "blobby",
                                            "triceratops", "fandisk", "retinal", "homer", "bunny00"};

/// A mesh name as a GoogleTest parameter name (letters, digits, '_' only).
inline std::string testName(std::string mesh) {
  for (char& c : mesh)
    if (c == '-') c = '_';
  return mesh;
}

}  // namespace t2stest
