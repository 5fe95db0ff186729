#include "calib/calibration_output.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include <cmath>
#include <fstream>

#include "camera/calib_io.hpp"
#include "common/error.hpp"

namespace ovo::calib {
namespace fs = std::filesystem;
namespace {

void writeFile(const fs::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary);
  if (!out) fail("{}: cannot create the file", file.string());
  out << text;
  if (!out) fail("{}: write failed", file.string());
}

std::string num(double v) { return fmt::format("{:.17g}", v); }

std::string list(std::initializer_list<double> v) {
  std::string out = "[";
  for (double x : v) out += (out.size() > 1 ? ", " : "") + num(x);
  return out + "]";
}

// Kalibr's camchain layout (cam0), which Kalibr, Basalt's and OpenVINS' loaders and ovo's
// camera::loadCamera read. No T_cam_imu: a camera calibration alone has no IMU.
std::string kalibrCamchain(const camera::Camera& cam) {
  std::string model_lines;
  if (const auto* kb = std::get_if<camera::KannalaBrandtCamera>(&cam)) {
    const auto& p = kb->params();
    model_lines =
        fmt::format("  distortion_model: equidistant\n  distortion_coeffs: {}\n  intrinsics: {}\n",
                    list({p.k1, p.k2, p.k3, p.k4}), list({p.fx, p.fy, p.cx, p.cy}));
  } else if (const auto* pin = std::get_if<camera::PinholeRadtanCamera>(&cam)) {
    const auto& p = pin->params();
    model_lines =
        fmt::format("  distortion_model: radtan\n  distortion_coeffs: {}\n  intrinsics: {}\n",
                    list({p.k1, p.k2, p.p1, p.p2}), list({p.fx, p.fy, p.cx, p.cy}));
  } else {
    fail("Kalibr camchain: an OCamCalib camera has no Kalibr form");
  }
  return fmt::format(
      "# Written by ovo calibrate (Kalibr camchain layout, camera only).\ncam0:\n"
      "  camera_model: pinhole\n{}  resolution: [{}, {}]\n",
      model_lines, camera::width(cam), camera::height(cam));
}

std::string cornersText(const CalibrationRun& run) {
  std::string out = fmt::format(
      "# image index u v X Y Z: corners in pixels (u = column, v = row), board coordinates in "
      "squares of {} m ({}x{} inner corners); ovo calibrate camera --corners reads this file\n",
      run.board.square_m, run.board.cols, run.board.rows);
  for (const BoardObservation& b : run.detected)
    for (std::size_t i = 0; i < b.size(); ++i)
      out += fmt::format("{} {} {:.4f} {:.4f} {:.6g} {:.6g} 0\n", b.image, i, b.corners_px[i].x(),
                         b.corners_px[i].y(), b.points_B[i].x() / run.board.square_m,
                         b.points_B[i].y() / run.board.square_m);
  return out;
}

nlohmann::json cameraJson(const camera::Camera& cam) {
  nlohmann::json j;
  j["model"] = camera::modelName(cam);
  if (const auto* o = std::get_if<camera::OcamCamera>(&cam)) {
    const auto& p = o->params();
    j["ss"] = p.ss;
    j["invpol"] = p.invpol;
    j["center_row"] = p.center_row;
    j["center_col"] = p.center_col;
    j["affine_cde"] = {p.c, p.d, p.e};
    j["max_off_axis_deg"] = o->maxOffAxisRad() * 180.0 / M_PI;
    j["invpol_round_trip_max_px"] = o->roundTrip().max_px;
  } else if (const auto* kb = std::get_if<camera::KannalaBrandtCamera>(&cam)) {
    const auto& p = kb->params();
    j["intrinsics_fx_fy_cx_cy"] = {p.fx, p.fy, p.cx, p.cy};
    j["distortion_k1_k4"] = {p.k1, p.k2, p.k3, p.k4};
  } else if (const auto* pin = std::get_if<camera::PinholeRadtanCamera>(&cam)) {
    const auto& p = pin->params();
    j["intrinsics_fx_fy_cx_cy"] = {p.fx, p.fy, p.cx, p.cy};
    j["distortion_k1_k2_p1_p2"] = {p.k1, p.k2, p.p1, p.p2};
  }
  return j;
}


}  // namespace

std::vector<std::string> calibrationFileNames(CameraModelKind model) {
  if (model == CameraModelKind::kOcam) return {"calib_results.txt"};
  return {"camchain.yaml", "sensor.yaml"};
}

nlohmann::json reportJson(const CalibrationRun& run) {
  const CalibrationResult& r = run.result;
  nlohmann::json j;
  j["model"] = modelKindName(r.model);
  j["image_width"] = r.width;
  j["image_height"] = r.height;
  j["rms_px"] = r.rms_px;
  j["mean_error_px"] = r.mean_error_px;
  j["mean_of_image_means_px"] = r.mean_of_image_means_px;
  j["init_rms_px"] = r.init_rms_px;
  j["corners_used"] = r.corners_used;
  j["images_used"] = nlohmann::json::array();
  j["per_image_rms_px"] = nlohmann::json::object();
  j["per_image_mean_px"] = nlohmann::json::object();
  for (std::size_t k = 0; k < r.boards.size(); ++k) {
    j["images_used"].push_back(r.boards[k].image);
    j["per_image_rms_px"][r.boards[k].image] = r.per_image_rms_px[k];
    j["per_image_mean_px"][r.boards[k].image] = r.per_image_mean_px[k];
  }
  if (run.selection) {
    const ModelSelection& sel = *run.selection;
    nlohmann::json& m = j["model_selection"];
    m["method"] = sel.folds == 0 ? "none (too few boards)"
                  : sel.folds == static_cast<int>(sel.images.size())
                      ? "leave-one-image-out"
                      : fmt::format("{}-fold over images", sel.folds);
    m["images"] = sel.images;
    m["candidates"] = nlohmann::json::array();
    for (const CandidateScore& c : sel.scores) {
      nlohmann::json e = {{"name", candidateName(c.candidate)},
                          {"model", modelKindName(c.candidate.model)},
                          {"board_shape", boardShapeName(c.candidate.board_shape)},
                          {"parameters", c.parameters}};
      if (c.candidate.model == CameraModelKind::kOcam) e["degree"] = c.candidate.degree;
      e["train_rms_px"] = std::isfinite(c.train_rms_px) ? nlohmann::json(c.train_rms_px) : nullptr;
      e["heldout_rms_px"] =
          std::isfinite(c.heldout_rms_px) ? nlohmann::json(c.heldout_rms_px) : nullptr;
      e["heldout_failed"] = c.heldout_failed;
      m["candidates"].push_back(e);
    }
    const CandidateScore& chosen = sel.scores[sel.chosen];
    m["chosen"] = candidateName(chosen.candidate);
    m["reason"] = sel.reason;
    m["per_image_heldout_rms_px"] = nlohmann::json::object();
    for (std::size_t k = 0; k < sel.images.size(); ++k) {
      const double v = k < chosen.heldout_per_image_rms_px.size()
                           ? chosen.heldout_per_image_rms_px[k]
                           : std::numeric_limits<double>::quiet_NaN();
      m["per_image_heldout_rms_px"][sel.images[k]] =
          std::isfinite(v) ? nlohmann::json(v) : nullptr;
    }
    m["outliers"] = nlohmann::json::array();
    for (std::size_t k = 0; k < sel.outliers.size(); ++k)
      m["outliers"].push_back(
          {{"image", sel.outliers[k]}, {"heldout_rms_px", sel.outlier_rms_px[k]}});
  }
  j["images_excluded"] = run.excluded;
  j["images_rejected"] = nlohmann::json::array();
  for (const auto* list : {&run.not_detected, &r.rejected})
    for (const RejectedImage& rej : *list)
      j["images_rejected"].push_back({{"image", rej.image}, {"reason", rej.reason}});
  j["board"] = {
      {"cols", run.board.cols},         {"rows", run.board.rows},
      {"square_m", run.board.square_m}, {"shape", boardShapeName(run.options.board_shape)},
      {"shear", r.board_shear},         {"stretch", r.board_stretch}};
  j["options"] = {{"ocam_degree", run.options.ocam_degree},
                  {"huber_px", run.options.huber_px},
                  {"reject_rms_px", run.options.reject_rms_px},
                  {"reject_factor", run.options.reject_factor}};
  j["source"] = run.source;
  j["detected_by"] = run.detected_by;
  if (r.camera) j["camera"] = cameraJson(*r.camera);
  j["files"] = calibrationFileNames(r.model);
  j["notes"] = r.notes;
  if (run.reference) {
    j["reference"] = {{"file", run.reference_file},
                      {"max_bearing_error_deg", run.reference->max_deg},
                      {"rms_bearing_error_deg", run.reference->rms_deg},
                      {"roll_deg", run.reference->roll_deg},
                      {"max_bearing_error_unaligned_deg", run.reference->max_unaligned_deg},
                      {"pixels", run.reference->pixels},
                      {"pixels_not_unprojected", run.reference->missing}};
  }
  return j;
}

void writeCalibrationOutputs(const fs::path& folder, const CalibrationRun& run) {
  const CalibrationResult& r = run.result;
  if (!r.camera) fail("calibration: no camera model to write");
  if (r.model == CameraModelKind::kOcam) {
    camera::writeOcamCalib(folder / "calib_results.txt", std::get<camera::OcamCamera>(*r.camera));
  } else {
    writeFile(folder / "camchain.yaml", kalibrCamchain(*r.camera));
    camera::writeSensorYaml(folder / "sensor.yaml", *r.camera, SE3::Identity(), 20.0);
  }
  writeFile(folder / "corners.txt", cornersText(run));
  writeFile(folder / "report.json", reportJson(run).dump(2) + "\n");
  writeFile(folder / "report.html", reportHtml(run));
}

}  // namespace ovo::calib
