#include "calib/corners_file.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "common/error.hpp"

namespace ovo::calib {
namespace {

bool parseNumber(const std::string& token, double* value) {
  char* end = nullptr;
  *value = std::strtod(token.c_str(), &end);
  return end != token.c_str() && *end == '\0' && std::isfinite(*value);
}

}  // namespace

std::vector<BoardObservation> readCornersFile(const std::filesystem::path& file, double square_m,
                                              int width, int height) {
  const std::string name = file.string();
  if (!std::filesystem::is_regular_file(file)) fail("{}: corner file not found", name);
  std::ifstream in(file);
  if (!in) fail("{}: cannot open the corner file", name);
  std::vector<BoardObservation> out;
  std::map<std::string, std::size_t> index_of;  // image name -> position in out
  bool new_block = true;                        // form "U V X Y": the next line starts an image
  int form = 0;                                 // tokens per line, fixed by the first data line
  std::string raw;
  for (long line = 1; std::getline(in, raw); ++line) {
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    const auto first = raw.find_first_not_of(" \t");
    if (first == std::string::npos) {
      new_block = true;
      continue;
    }
    if (raw[first] == '#') continue;
    std::istringstream tokens(raw);
    std::vector<std::string> t;
    for (std::string s; tokens >> s;) t.push_back(s);
    if (form == 0) form = static_cast<int>(t.size());
    if (form != 4 && form != 5 && form != 7)
      failAt(name, line,
             "expected 'IMAGE INDEX U V X Y Z', 'IMAGE U V X Y' or 'U V X Y', got {} fields",
             t.size());
    if (static_cast<int>(t.size()) != form)
      failAt(name, line, "expected {} fields like the first data line, got {}", form, t.size());
    const std::size_t first_number = form == 7 ? 2 : form == 5 ? 1 : 0;
    double v[5] = {0, 0, 0, 0, 0};
    const std::size_t count = form == 7 ? 5 : 4;
    for (std::size_t k = 0; k < count; ++k)
      if (!parseNumber(t[first_number + k], &v[k]))
        failAt(name, line, "'{}' is not a finite number", t[first_number + k]);
    if (form == 7 && v[4] != 0.0) failAt(name, line, "Z must be 0 on a planar board, got {}", v[4]);
    std::string image;
    if (form == 4) {
      if (new_block) out.push_back({});
      new_block = false;
      image = fmt::format("board_{}", out.size());
      out.back().image = image;
    } else {
      image = t[0];
      auto it = index_of.find(image);
      if (it == index_of.end()) {
        it = index_of.emplace(image, out.size()).first;
        out.push_back({});
        out.back().image = image;
      }
      if (it->second + 1 != out.size())
        failAt(name, line, "the corners of image '{}' are not on consecutive lines", image);
    }
    BoardObservation& obs = out.back();
    obs.width = width;
    obs.height = height;
    obs.corners_px.emplace_back(v[0], v[1]);
    obs.points_B.emplace_back(v[2] * square_m, v[3] * square_m, 0.0);
  }
  if (out.empty()) fail("{}: the corner file holds no corners", name);
  return out;
}

}  // namespace ovo::calib
