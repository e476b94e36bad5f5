// The studio's test torso (tests/data/studio) for the C++ tests of the region check: where it lies, a
// file's text and a face list as the studio page sends it.
#pragma once

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace kgd {

inline const std::string kStudioDataDir = std::string(KGD_SOURCE_DIR) + "/tests/data/studio/";

inline std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// "3 5 8 ": body face indices separated by spaces (the region check's "faces" part).
inline std::string JoinFaces(const std::vector<int>& faces) {
  std::string s;
  for (int f : faces) s += std::to_string(f) + " ";
  return s;
}

}  // namespace kgd
