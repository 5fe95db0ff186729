#include "camera/calib_io.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "common/so3.hpp"
#include "common/text.hpp"
#include "common/yaml_keys.hpp"

namespace ovo::camera {
namespace fs = std::filesystem;
namespace {

std::string readText(const fs::path& file, const char* what) {
  if (!fs::exists(file)) fail("{}: {} file not found", file.string(), what);
  std::ifstream in(file, std::ios::binary);
  if (!in) fail("{}: cannot open {} file", file.string(), what);
  std::stringstream text;
  text << in.rdbuf();
  std::string out = text.str();
  eraseUtf8Bom(out);
  return out;
}

// ---- OCamCalib calib_results.txt -------------------------------------------------------------

struct DataLine {
  long line = 0;
  std::vector<double> values;
};

double parseNumber(const std::string& file, long line, const std::string& token) {
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (end == token.c_str() || *end != '\0') failAt(file, line, "'{}' is not a number", token);
  if (!std::isfinite(v)) failAt(file, line, "'{}' is not a finite number", token);
  return v;
}

// The non-blank, non-comment lines of the file, parsed into numbers.
std::vector<DataLine> ocamDataLines(const fs::path& file) {
  const std::string text = readText(file, "OCamCalib calibration");
  std::istringstream in(text);
  std::vector<DataLine> lines;
  std::string raw;
  for (long number = 1; std::getline(in, raw); ++number) {
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    const auto first = raw.find_first_not_of(" \t");
    if (first == std::string::npos || raw[first] == '#') continue;
    DataLine data{number, {}};
    std::istringstream tokens(raw);
    for (std::string token; tokens >> token;)
      data.values.push_back(parseNumber(file.string(), number, token));
    lines.push_back(std::move(data));
  }
  return lines;
}

// "N v_1 .. v_N" -> the N values.
std::vector<double> countedValues(const std::string& file, const DataLine& data, const char* name) {
  const auto& v = data.values;
  const double count = v.front();
  if (count != std::floor(count) || count < 1 || count > 64)
    failAt(file, data.line, "{}: the first number must be the coefficient count (1..64), got {}",
           name, count);
  const auto n = static_cast<std::size_t>(count);
  if (v.size() - 1 != n)
    failAt(file, data.line, "{}: the count says {} coefficients but the line has {}", name, n,
           v.size() - 1);
  return {v.begin() + 1, v.end()};
}

int positiveInt(const std::string& file, long line, double v, const char* name) {
  if (v != std::floor(v) || v < 1 || v > 1e6)
    failAt(file, line, "{} must be a positive whole number, got {}", name, v);
  return static_cast<int>(v);
}

// Prints v with `format` when that reads back to the same double, else with all 17 digits.
std::string exactNumber(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  if (std::strtod(buf, nullptr) == v) return buf;
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// ---- YAML ------------------------------------------------------------------------------------

YAML::Node loadYaml(const fs::path& file) {
  std::string text = readText(file, "camera calibration");
  // OpenCV-style "%YAML:1.0" directive: not YAML 1.2; blank it (keeping the line numbers).
  if (text.rfind("%YAML", 0) == 0) text[0] = '#';
  YAML::Node doc;
  try {
    doc = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    failAt(file.string(), e.mark.line + 1, "invalid YAML: {}", e.msg);
  }
  checkYamlDocument(doc, file.string());
  return doc;
}

std::string where(const fs::path& file, const YAML::Node& node) {
  return fmt::format("{}:{}", file.string(), node.Mark().line + 1);
}

YAML::Node requireKey(const fs::path& file, const YAML::Node& parent, const std::string& key) {
  if (!parent.IsMap())
    fail("{}: expected a mapping holding '{}', got {}", where(file, parent), key,
         parent.IsSequence() ? "a list" : "a value");
  const YAML::Node node = parent[key];
  if (!node) fail("{}: missing key '{}'", where(file, parent), key);
  return node;
}

std::vector<double> numbers(const fs::path& file, const YAML::Node& node, const std::string& key,
                            std::size_t min_count, std::size_t max_count) {
  if (!node.IsSequence()) fail("{}: '{}' must be a list of numbers", where(file, node), key);
  std::vector<double> out;
  for (const auto& item : node) {
    if (item.IsSequence()) {  // Kalibr 4x4 as a list of rows
      for (double v : numbers(file, item, key, 0, 64)) out.push_back(v);
      continue;
    }
    double v = 0.0;
    try {
      v = item.as<double>();
    } catch (const YAML::Exception&) {
      fail("{}: '{}' must hold numbers, got '{}'", where(file, item), key, item.Scalar());
    }
    if (!std::isfinite(v)) fail("{}: '{}' holds a non-finite number", where(file, item), key);
    out.push_back(v);
  }
  if (out.size() < min_count || out.size() > max_count) {
    if (min_count == max_count)
      fail("{}: '{}' must have {} numbers, got {}", where(file, node), key, min_count, out.size());
    fail("{}: '{}' must have {} to {} numbers, got {}", where(file, node), key, min_count,
         max_count, out.size());
  }
  return out;
}

std::string text(const fs::path& file, const YAML::Node& node, const std::string& key) {
  if (!node.IsScalar()) fail("{}: '{}' must be a string", where(file, node), key);
  return node.Scalar();
}

SE3 transformFrom(const fs::path& file, const YAML::Node& node, const std::string& key,
                  const std::vector<double>& m16) {
  Eigen::Matrix4d M = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(m16.data());
  if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9)
    fail("{}: '{}' last row must be 0 0 0 1", where(file, node), key);
  const Mat3 R = M.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff() > 1e-4 || R.determinant() < 0)
    fail("{}: '{}' rotation part is not a rotation matrix", where(file, node), key);
  SE3 T = SE3::Identity();
  T.linear() = so3::orthonormalize(R);
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

// The camera block: the document itself (EuRoC sensor.yaml) or its cam0 (Kalibr camchain).
YAML::Node cameraBlock(const fs::path& file, const YAML::Node& doc) {
  if (!doc.IsMap()) fail("{}: expected a YAML mapping at the top", file.string());
  if (const YAML::Node cam0 = doc["cam0"]) {
    // A value or a list there: yaml-cpp's operator[] on it threw its own exception (fuzzing).
    if (!cam0.IsMap()) fail("{}: 'cam0' must be a mapping (the camera's keys)", where(file, cam0));
    return cam0;
  }
  return doc;
}

Camera cameraFromYaml(const fs::path& file) {
  const YAML::Node doc = loadYaml(file);
  const YAML::Node cam = cameraBlock(file, doc);
  const std::string model = text(file, requireKey(file, cam, "camera_model"), "camera_model");
  if (model != "pinhole")
    fail(
        "{}: camera_model '{}' is not supported (expected pinhole, with distortion_model "
        "radial-tangential/radtan or equidistant); OCamCalib cameras use calib_results.txt",
        where(file, cam["camera_model"]), model);
  const auto size = numbers(file, requireKey(file, cam, "resolution"), "resolution", 2, 2);
  const auto k = numbers(file, requireKey(file, cam, "intrinsics"), "intrinsics", 4, 4);
  // Checked before the conversion: a double beyond int's range does not convert (fuzzing).
  constexpr double kMaxSidePx = 100000.0;
  if (!(size[0] >= 1.0 && size[0] <= kMaxSidePx && size[1] >= 1.0 && size[1] <= kMaxSidePx) ||
      size[0] != std::floor(size[0]) || size[1] != std::floor(size[1]))
    fail("{}: 'resolution' must be two positive whole numbers [width, height], at most {}",
         where(file, cam["resolution"]), kMaxSidePx);
  const int width = static_cast<int>(size[0]), height = static_cast<int>(size[1]);
  if (!(k[0] > 0 && k[1] > 0))
    fail("{}: 'intrinsics' fu and fv must be positive", where(file, cam["intrinsics"]));
  if (!(k[2] >= 0 && k[2] < width && k[3] >= 0 && k[3] < height))
    fail("{}: 'intrinsics' principal point ({}, {}) lies outside the {}x{} image",
         where(file, cam["intrinsics"]), k[2], k[3], width, height);
  std::string distortion = "none";
  if (cam["distortion_model"]) distortion = text(file, cam["distortion_model"], "distortion_model");
  const char* coeff_key =
      cam["distortion_coefficients"] ? "distortion_coefficients" : "distortion_coeffs";
  const YAML::Node coeff_node = cam[coeff_key];
  if (distortion == "radial-tangential" || distortion == "radtan" || distortion == "none") {
    std::vector<double> d(5, 0.0);
    if (distortion != "none") {
      const auto read = numbers(file, requireKey(file, cam, coeff_key), coeff_key, 4, 5);
      std::copy(read.begin(), read.end(), d.begin());
    }
    return PinholeRadtanCamera(PinholeRadtanParams{.fx = k[0],
                                                   .fy = k[1],
                                                   .cx = k[2],
                                                   .cy = k[3],
                                                   .k1 = d[0],
                                                   .k2 = d[1],
                                                   .p1 = d[2],
                                                   .p2 = d[3],
                                                   .k3 = d[4],
                                                   .width = width,
                                                   .height = height});
  }
  if (distortion == "equidistant") {
    const auto d = numbers(file, requireKey(file, cam, coeff_key), coeff_key, 4, 4);
    return KannalaBrandtCamera(KannalaBrandtParams{.fx = k[0],
                                                   .fy = k[1],
                                                   .cx = k[2],
                                                   .cy = k[3],
                                                   .k1 = d[0],
                                                   .k2 = d[1],
                                                   .k3 = d[2],
                                                   .k4 = d[3],
                                                   .width = width,
                                                   .height = height});
  }
  fail(
      "{}: distortion_model '{}' is not supported (expected radial-tangential, radtan, "
      "equidistant or none)",
      where(file, cam["distortion_model"]), distortion);
}

bool looksLikeOcam(const fs::path& file) {
  const auto ext = file.extension().string();
  if (ext == ".txt") return true;
  if (ext == ".yaml" || ext == ".yml") return false;
  std::ifstream in(file);
  std::string first;
  std::getline(in, first);
  eraseUtf8Bom(first);
  return first.rfind("#polynomial", 0) == 0;
}

std::string list(const std::vector<double>& v) {
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i) out += fmt::format("{}{}", i ? ", " : "", v[i]);
  return out + "]";
}

}  // namespace

OcamCamera readOcamCalib(const fs::path& file, const OcamOptions& options) {
  const std::string name = file.string();
  const auto lines = ocamDataLines(file);
  static constexpr const char* kExpected[] = {
      "the ss line (count, then a0..aN)", "the invpol line (count, then the coefficients)",
      "the centre line (row column)", "the affine line (c d e)",
      "the image size line (height width)"};
  if (lines.size() < 5) {
    long last = lines.empty() ? 0 : lines.back().line;
    failAt(name, last + 1, "file ends early: expected {}", kExpected[lines.size()]);
  }
  if (lines.size() > 5) failAt(name, lines[5].line, "unexpected data after the image size line");
  OcamParams p;
  p.ss = countedValues(name, lines[0], "ss");
  p.invpol = countedValues(name, lines[1], "invpol");
  if (!(p.ss.front() < 0.0))
    failAt(name, lines[0].line, "ss: a0 must be negative (forward rays have z' < 0), got {}",
           p.ss.front());
  if (lines[2].values.size() != 2)
    failAt(name, lines[2].line, "centre: expected 2 numbers (row column), got {}",
           lines[2].values.size());
  p.center_row = lines[2].values[0];
  p.center_col = lines[2].values[1];
  if (lines[3].values.size() != 3)
    failAt(name, lines[3].line, "affine: expected 3 numbers (c d e), got {}",
           lines[3].values.size());
  p.c = lines[3].values[0];
  p.d = lines[3].values[1];
  p.e = lines[3].values[2];
  if (std::abs(p.c - p.d * p.e) < 1e-9)
    failAt(name, lines[3].line, "affine: c - d e must not be zero");
  if (lines[4].values.size() != 2)
    failAt(name, lines[4].line, "image size: expected 2 numbers (height width), got {}",
           lines[4].values.size());
  p.height = positiveInt(name, lines[4].line, lines[4].values[0], "image height");
  p.width = positiveInt(name, lines[4].line, lines[4].values[1], "image width");
  if (!(p.center_row >= 0 && p.center_row < p.height && p.center_col >= 0 &&
        p.center_col < p.width))
    failAt(name, lines[2].line, "centre (row {}, column {}) lies outside the {}x{} image",
           p.center_row, p.center_col, p.width, p.height);
  try {
    return OcamCamera(std::move(p), options);
  } catch (const Error& e) {
    fail("{}: {}", name, e.what());
  }
}

void writeOcamCalib(const fs::path& file, const OcamCamera& cam) {
  const OcamParams& p = cam.params();
  const std::vector<double>& invpol = p.invpol.empty() ? cam.projectionInvpol() : p.invpol;
  std::string out =
      "#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). These "
      "are used by cam2world\n\n";
  out += fmt::format("{} ", p.ss.size());
  for (double v : p.ss) out += exactNumber("%e", v) + " ";
  out +=
      "\n\n#polynomial coefficients for the inverse mapping function (ocam_model.invpol in "
      "MATLAB). These are used by world2cam\n\n";
  out += fmt::format("{} ", invpol.size());
  for (double v : invpol) out += exactNumber("%f", v) + " ";
  out += "\n\n#center: \"row\" and \"column\", starting from 0 (C convention)\n\n";
  out += exactNumber("%f", p.center_row) + " " + exactNumber("%f", p.center_col) + "\n";
  out += "\n#affine parameters \"c\", \"d\", \"e\"\n\n";
  out +=
      exactNumber("%f", p.c) + " " + exactNumber("%f", p.d) + " " + exactNumber("%f", p.e) + "\n";
  out += "\n#image size: \"height\" and \"width\"\n\n";
  out += fmt::format("{} {}\n\n", p.height, p.width);
  std::ofstream f(file, std::ios::binary);
  if (!f) fail("{}: cannot write the OCamCalib calibration", file.string());
  f << out;
  if (!f) fail("{}: write failed", file.string());
}

void writeSensorYaml(const fs::path& file, const Camera& cam, const SE3& T_B_C, double rate_hz) {
  std::string model_lines;
  if (const auto* pin = std::get_if<PinholeRadtanCamera>(&cam)) {
    const auto& p = pin->params();
    std::vector<double> d{p.k1, p.k2, p.p1, p.p2};
    if (p.k3 != 0.0) d.push_back(p.k3);
    model_lines = fmt::format(
        "intrinsics: {} #fu, fv, cu, cv\ndistortion_model: radial-tangential\n"
        "distortion_coefficients: {}\n",
        list({p.fx, p.fy, p.cx, p.cy}), list(d));
  } else if (const auto* kb = std::get_if<KannalaBrandtCamera>(&cam)) {
    const auto& p = kb->params();
    model_lines = fmt::format(
        "intrinsics: {} #fu, fv, cu, cv\ndistortion_model: equidistant\n"
        "distortion_coefficients: {}\n",
        list({p.fx, p.fy, p.cx, p.cy}), list({p.k1, p.k2, p.k3, p.k4}));
  } else {
    fail(
        "{}: an OCamCalib camera has no sensor.yaml form; write calib_results.txt "
        "(writeOcamCalib)",
        file.string());
  }
  const Eigen::Matrix4d M = T_B_C.matrix();
  std::string data;
  for (int r = 0; r < 4; ++r) {
    data += r ? ",\n         " : "";
    for (int c = 0; c < 4; ++c) data += fmt::format("{}{}", c ? ", " : "", M(r, c));
  }
  const std::string out = fmt::format(
      "%YAML:1.0\n# General sensor definitions.\nsensor_type: camera\ncomment: written by ovo\n\n"
      "# Sensor extrinsics wrt. the body-frame.\nT_BS:\n  cols: 4\n  rows: 4\n  data: [{}]\n\n"
      "# Camera specific definitions.\nrate_hz: {}\nresolution: [{}, {}]\ncamera_model: "
      "pinhole\n{}",
      data, rate_hz, width(cam), height(cam), model_lines);
  std::ofstream f(file, std::ios::binary);
  if (!f) fail("{}: cannot write the camera sensor.yaml", file.string());
  f << out;
  if (!f) fail("{}: write failed", file.string());
}

std::optional<SE3> readSensorYamlExtrinsics(const fs::path& file) {
  if (looksLikeOcam(file)) return std::nullopt;  // OCamCalib files hold no extrinsics
  const YAML::Node doc = loadYaml(file);
  const YAML::Node cam = cameraBlock(file, doc);
  if (const YAML::Node T = cam["T_BS"]) {
    const YAML::Node data = T.IsMap() ? requireKey(file, T, "data") : T;
    return transformFrom(file, data, "T_BS", numbers(file, data, "T_BS", 16, 16));
  }
  if (const YAML::Node T = cam["T_imu_cam"])
    return transformFrom(file, T, "T_imu_cam", numbers(file, T, "T_imu_cam", 16, 16));
  if (const YAML::Node T = cam["T_cam_imu"])
    return transformFrom(file, T, "T_cam_imu", numbers(file, T, "T_cam_imu", 16, 16)).inverse();
  return std::nullopt;
}

Camera loadCamera(const fs::path& file) {
  if (!fs::exists(file)) fail("{}: camera calibration file not found", file.string());
  if (looksLikeOcam(file)) return readOcamCalib(file);
  return cameraFromYaml(file);
}

}  // namespace ovo::camera
