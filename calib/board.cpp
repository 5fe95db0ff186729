#include "calib/board.hpp"

#include <cmath>
#include <regex>

#include "common/error.hpp"

namespace ovo::calib {

Vec3 BoardSpec::point(int k) const {
  return Vec3((k % cols) * square_m, (k / cols) * square_m, 0.0);
}

BoardSpec parseBoardSpec(const std::string& text, double square_m, const std::string& option) {
  static const std::regex kPattern(R"(\s*(\d{1,3})\s*[xX]\s*(\d{1,3})\s*)");
  std::smatch m;
  if (!std::regex_match(text, m, kPattern))
    fail("{}: expected the inner corners as COLSxROWS (e.g. 8x6), got '{}'", option, text);
  BoardSpec spec{std::stoi(m[1]), std::stoi(m[2]), square_m};
  if (spec.cols < 2 || spec.rows < 2)
    fail("{}: a board needs at least 2x2 inner corners, got '{}'", option, text);
  if (!(std::isfinite(square_m) && square_m > 0.0 && square_m < 10.0))
    fail("--square: expected the square size in metres (0 < size < 10), got {}", square_m);
  return spec;
}

}  // namespace ovo::calib
