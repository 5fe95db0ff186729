// `ovo calibrate camera`: intrinsics from checkerboard images (or from a corner file) with
// calib/ (detection, Scaramuzza's initialisation, Ceres refinement), written with a report.
// `ovo calibrate rig`: the camera-to-body rotation and the camera-gyro time offset from a
// dataset with rotation (calib/rig_calibration), written as a rig.yaml.
// Everything goes through a staging folder or file: a failed run writes nothing.
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>

#include "apps/command.hpp"
#include "calib/board_detector.hpp"
#include "calib/calibration_output.hpp"
#include "calib/camera_calibration.hpp"
#include "calib/corners_file.hpp"
#include "calib/model_comparison.hpp"
#include "calib/model_selection.hpp"
#include "calib/rig_calibration.hpp"
#include "camera/calib_io.hpp"
#include "common/config.hpp"
#include "common/error.hpp"
#include "frontend/frontend.hpp"
#include "io/dataset.hpp"
#include "io/image_decode.hpp"
#include "io/staged_folder.hpp"

namespace ovo::app {
namespace {
namespace fs = std::filesystem;

// ---- camera ------------------------------------------------------------------------------------

struct CameraArgs {
  std::string images, corners, board, model = "ocam", out, reference, image_size;
  std::string board_shape = "auto";
  double square_m = 0.0;
  int degree = 0;                    // 0: chosen by held-out error among 3-6
  std::vector<std::string> exclude;  // images left out by the user
  int min_boards = 3;
  double huber_px = 1.0;
  bool no_views = false;
};

const std::set<std::string> kCameraOutputNames = {"calib_results.txt", "camchain.yaml",
                                                  "sensor.yaml",       "corners.txt",
                                                  "report.json",       "report.html"};

// "Fisheye1_2.jpg" before "Fisheye1_10.jpg": digit runs compare as numbers.
bool naturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) &&
        std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t i2 = i, j2 = j;
      while (i2 < a.size() && std::isdigit(static_cast<unsigned char>(a[i2]))) ++i2;
      while (j2 < b.size() && std::isdigit(static_cast<unsigned char>(b[j2]))) ++j2;
      const std::string na = a.substr(i, i2 - i), nb = b.substr(j, j2 - j);
      const std::string ta = na.substr(std::min(na.find_first_not_of('0'), na.size() - 1));
      const std::string tb = nb.substr(std::min(nb.find_first_not_of('0'), nb.size() - 1));
      if (ta.size() != tb.size()) return ta.size() < tb.size();
      if (ta != tb) return ta < tb;
      i = i2;
      j = j2;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

std::vector<fs::path> listImages(const fs::path& dir) {
  if (!fs::is_directory(dir)) fail("--images {}: folder not found", dir.string());
  static const std::set<std::string> kExtensions = {".png", ".jpg",  ".jpeg", ".bmp",
                                                    ".tif", ".tiff", ".pgm",  ".ppm"};
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (kExtensions.count(ext)) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) {
    return naturalLess(a.filename().string(), b.filename().string());
  });
  if (files.empty())
    fail("--images {}: no images in the folder (expected .png, .jpg, .bmp, .tif or .pgm files)",
         dir.string());
  return files;
}

struct LoadedImage {
  std::string name;
  cv::Mat grey;
};

// Reads every image; unreadable ones are rejected, mixed sizes are an error naming the images.
std::vector<LoadedImage> loadImages(const std::vector<fs::path>& files,
                                    std::vector<calib::RejectedImage>* rejected) {
  std::vector<LoadedImage> images(files.size());
  tbb::parallel_for(std::size_t{0}, files.size(), [&](std::size_t k) {
    images[k].name = files[k].filename().string();
    try {  // ovo's reader: only the image formats, checked before OpenCV sees them
      images[k].grey = io::readImageGrey(files[k]);
    } catch (const Error&) {
      images[k].grey.release();
    }
  });
  std::vector<LoadedImage> ok;
  std::map<std::pair<int, int>, std::vector<std::string>> by_size;
  for (auto& image : images) {
    if (image.grey.empty()) {
      rejected->push_back({image.name, "cannot read or decode the image"});
      continue;
    }
    by_size[{image.grey.cols, image.grey.rows}].push_back(image.name);
    ok.push_back(std::move(image));
  }
  if (by_size.size() > 1) {
    std::string sizes;
    for (const auto& [size, names] : by_size) {
      std::string list;
      for (std::size_t k = 0; k < names.size() && k < 6; ++k) list += (k ? ", " : "") + names[k];
      if (names.size() > 6) list += fmt::format(" and {} more", names.size() - 6);
      sizes += fmt::format("\n  {}x{}: {} image{} ({})", size.first, size.second, names.size(),
                           names.size() == 1 ? "" : "s", list);
    }
    fail(
        "--images: the images have different sizes; one calibration is for one camera (one "
        "size):{}",
        sizes);
  }
  return ok;
}

std::string rejectedList(const std::vector<calib::RejectedImage>& rejected) {
  std::string out;
  for (const auto& r : rejected) out += fmt::format("\n  {}: {}", r.image, r.reason);
  return out;
}

std::pair<int, int> parseImageSize(const std::string& text) {
  static const std::regex kPattern(R"((\d{1,5})[xX](\d{1,5}))");
  std::smatch m;
  if (!std::regex_match(text, m, kPattern) || std::stoi(m[1]) <= 0 || std::stoi(m[2]) <= 0)
    fail("--image-size: expected WIDTHxHEIGHT in pixels (e.g. 1032x778), got '{}'", text);
  return {std::stoi(m[1]), std::stoi(m[2])};
}

int runCalibrateCamera(const CameraArgs& args) {
  if (args.images.empty() && args.corners.empty())
    fail("calibrate camera: give --images DIR (checkerboard images) or --corners FILE");
  const calib::BoardSpec board = calib::parseBoardSpec(args.board, args.square_m);
  calib::CalibrationOptions options;
  options.model = calib::parseCameraModel(args.model);
  const bool auto_shape = args.board_shape == "auto";
  options.board_shape = auto_shape ? calib::BoardShape::kShared
                                   : calib::parseBoardShape(args.board_shape, "--board-shape");
  if (args.degree != 0 && (args.degree < 2 || args.degree > 7))
    fail("--degree: expected an OCam polynomial degree of 2 to 7 (or 0 to choose), got {}",
         args.degree);
  if (args.degree != 0 && options.model != calib::CameraModelKind::kOcam)
    fail("--degree: only the ocam model has a polynomial degree, not --model {}", args.model);
  options.ocam_degree = args.degree == 0 ? 4 : args.degree;
  options.min_boards = args.min_boards;
  options.huber_px = args.huber_px;
  std::optional<camera::Camera> reference;
  if (!args.reference.empty()) reference = camera::loadCamera(args.reference);
  // The output folder is checked before any work.
  io::StagedFolder out(args.out, "--out", io::StagedFolder::Replace::kIfOwnOutput,
                       kCameraOutputNames);

  calib::CalibrationRun run;
  run.board = board;
  run.options = options;
  std::vector<LoadedImage> images;
  if (!args.corners.empty()) {
    int width = 0, height = 0;
    if (!args.image_size.empty()) {
      std::tie(width, height) = parseImageSize(args.image_size);
    } else if (!args.images.empty()) {
      images = loadImages(listImages(args.images), &run.not_detected);
      if (images.empty()) fail("--images {}: no readable image to take the size from", args.images);
      width = images.front().grey.cols;
      height = images.front().grey.rows;
    } else {
      fail("--corners: give the image size with --image-size WIDTHxHEIGHT (or --images DIR)");
    }
    run.detected = calib::readCornersFile(args.corners, board.square_m, width, height);
    run.source = fs::path(args.corners).filename().string();
    for (const auto& b : run.detected) run.images.push_back(b.image);
  } else {
    images = loadImages(listImages(args.images), &run.not_detected);
    run.source = "detector";
    for (const auto& image : images) run.images.push_back(image.name);
    std::vector<calib::Detection> detections(images.size());
    tbb::parallel_for(std::size_t{0}, images.size(), [&](std::size_t k) {
      detections[k] = calib::detectBoard(images[k].grey, board, images[k].name);
    });
    for (std::size_t k = 0; k < images.size(); ++k) {
      if (detections[k].board) {
        run.detected.push_back(*detections[k].board);
        run.detected_by[images[k].name] = detections[k].method;
      }
    }
    spdlog::info("calibrate: {} of {} images with a {}x{} board", run.detected.size(),
                 images.size() + run.not_detected.size(), board.cols, board.rows);
    if (static_cast<int>(run.detected.size()) < options.min_boards) {
      std::vector<calib::RejectedImage> all = run.not_detected;
      for (std::size_t k = 0; k < images.size(); ++k)
        if (!detections[k].board) all.push_back({images[k].name, detections[k].reason});
      fail(
          "calibrate: {} board{} found in {} images, at least {} are needed (is --board {} the "
          "number of inner corners, columns x rows?):{}",
          run.detected.size(), run.detected.size() == 1 ? "" : "s",
          images.size() + run.not_detected.size(), options.min_boards, args.board,
          rejectedList(all));
    }
    // Second pass: boards missed in the raw image, looked for in perspective views through a
    // first calibration.
    std::vector<std::size_t> missed;
    for (std::size_t k = 0; k < images.size(); ++k)
      if (!detections[k].board) missed.push_back(k);
    if (!missed.empty() && !args.no_views) {
      const calib::CalibrationResult first = calib::calibrateCamera(run.detected, options);
      tbb::parallel_for(std::size_t{0}, missed.size(), [&](std::size_t m) {
        const std::size_t k = missed[m];
        calib::Detection d =
            calib::detectBoardInViews(images[k].grey, board, images[k].name, *first.camera);
        if (d.board || d.reason.find("refused") != std::string::npos) detections[k] = d;
      });
      for (std::size_t k : missed)
        if (detections[k].board) {
          run.detected.push_back(*detections[k].board);
          run.detected_by[images[k].name] = detections[k].method;
          spdlog::info("calibrate: {}: board found in a perspective view", images[k].name);
        }
    }
    for (std::size_t k : missed)
      if (!detections[k].board) run.not_detected.push_back({images[k].name, detections[k].reason});
  }

  // --exclude: boards the user leaves out (each must name a board that was found).
  for (const std::string& name : args.exclude) {
    const auto it = std::find_if(run.detected.begin(), run.detected.end(),
                                 [&](const calib::BoardObservation& b) { return b.image == name; });
    if (it == run.detected.end())
      fail("--exclude {}: no board of that image was found (boards found: {})", name,
           [&] {
             std::string list;
             for (const auto& b : run.detected) list += (list.empty() ? "" : ", ") + b.image;
             return list;
           }());
    run.detected.erase(it);
    run.excluded.push_back(name);
  }

  // The candidates: the degree and the board shape the user did not fix, scored by their
  // held-out error.
  const std::vector<calib::ModelCandidate> candidates = calib::modelCandidates(
      options.model, args.degree,
      auto_shape ? std::nullopt : std::optional<calib::BoardShape>(options.board_shape));
  run.selection = calib::selectModel(run.detected, candidates, options);
  const calib::ModelCandidate& chosen = run.selection->scores[run.selection->chosen].candidate;
  options.ocam_degree = chosen.degree;
  options.board_shape = chosen.board_shape;
  run.options = options;
  for (const auto& c : run.selection->scores)
    spdlog::info("calibrate: {:<30} {:2d} parameters, RMS {:.4f} px, held out {:.4f} px{}",
                 calib::candidateName(c.candidate), c.parameters, c.train_rms_px,
                 c.heldout_rms_px, &c == &run.selection->scores[run.selection->chosen] ? " <-" : "");
  spdlog::info("calibrate: chose {}: {}", calib::candidateName(chosen), run.selection->reason);
  for (std::size_t k = 0; k < run.selection->outliers.size(); ++k)
    spdlog::warn(
        "calibrate: {}: its corners are predicted to {:.3f} px when it is left out, clearly worse "
        "than the other images' (look at it; --exclude {} leaves it out)",
        run.selection->outliers[k], run.selection->outlier_rms_px[k], run.selection->outliers[k]);

  run.result = calib::calibrateCamera(run.detected, options);
  if (reference) {
    if (camera::width(*reference) != run.result.width ||
        camera::height(*reference) != run.result.height)
      fail("--reference {}: it is for {}x{} images, the calibration for {}x{}", args.reference,
           camera::width(*reference), camera::height(*reference), run.result.width,
           run.result.height);
    run.reference = calib::compareBearings(*reference, *run.result.camera);
    run.reference_file = args.reference;
  }
  calib::writeCalibrationOutputs(out.staging(), run);
  out.commit();
  const auto& r = run.result;
  spdlog::info(
      "calibrate: {} model from {} images ({} corners): RMS {:.3f} px, mean of image means "
      "{:.3f} px; {} rejected; wrote {}",
      calib::modelKindName(r.model), r.boards.size(), r.corners_used, r.rms_px,
      r.mean_of_image_means_px, run.not_detected.size() + r.rejected.size(), args.out);
  for (const auto& rej : run.not_detected) spdlog::info("  rejected {}: {}", rej.image, rej.reason);
  for (const auto& rej : r.rejected) spdlog::info("  rejected {}: {}", rej.image, rej.reason);
  if (run.reference)
    spdlog::info(
        "  against {}: bearings within {:.4f} deg (RMS {:.4f} deg) after a roll of {:.4f} deg "
        "about the optical axis; {:.4f} deg without it",
        args.reference, run.reference->max_deg, run.reference->rms_deg, run.reference->roll_deg,
        run.reference->max_unaligned_deg);
  return 0;
}

void setupCamera(CLI::App& app, const std::shared_ptr<CameraArgs>& args) {
  app.add_option("--images", args->images, "Folder of checkerboard images");
  app.add_option("--corners", args->corners,
                 "Corner file instead of detection ('IMAGE INDEX U V X Y Z', X Y in squares)");
  app.add_option("--image-size", args->image_size, "With --corners: WIDTHxHEIGHT in pixels");
  app.add_option("--board", args->board, "Inner corners, COLSxROWS (e.g. 8x6)")->required();
  app.add_option("--square", args->square_m, "Square size in metres")->required();
  app.add_option("--model", args->model, "ocam | kb | pinhole")->capture_default_str();
  app.add_option("--out", args->out, "Output folder")->required();
  app.add_option("--degree", args->degree,
                 "OCam polynomial degree (default: the one of 3-6 with the lowest held-out error)");
  app.add_option("--board-shape", args->board_shape,
                 "auto (rigid or shared, by held-out error) | rigid | shared (one shear and "
                 "stretch of the printed board) | per-board")
      ->capture_default_str();
  app.add_option("--exclude", args->exclude,
                 "Images to leave out (comma-separated names, e.g. a blurred view the report "
                 "names)")
      ->delimiter(',');
  app.add_option("--min-boards", args->min_boards, "Fewest usable boards")->capture_default_str();
  app.add_option("--huber", args->huber_px, "Robust loss scale (pixels; 0: none)")
      ->capture_default_str();
  app.add_option("--reference", args->reference,
                 "A calibration of the same camera to compare bearings with");
  app.add_flag("--no-views", args->no_views,
               "Do not look for missed boards in perspective views of a first calibration");
}

// ---- rig ---------------------------------------------------------------------------------------

struct RigArgs {
  std::string dataset, out, config;
  double max_offset_s = 0.1;
  std::vector<std::string> sets;
};

// The dataset's rig.yaml with T_B_C and camera.time_offset_s replaced (or, without one, a rig.yaml
// of the dataset's rig figures), with a header saying where the numbers came from.
std::string rigYaml(const io::Dataset& data, const fs::path& rig_file, const SE3& T_B_C,
                    const calib::RigCalibration& r) {
  YAML::Node doc;
  if (fs::exists(rig_file)) {
    doc = YAML::LoadFile(rig_file.string());
  } else {
    const auto seq = [](const SE3& T) {
      YAML::Node n;
      for (int i = 0; i < 16; ++i) n.push_back(T.matrix()(i / 4, i % 4));
      n.SetStyle(YAML::EmitterStyle::Flow);
      return n;
    };
    doc["T_B_L"] = seq(data.rig.T_B_L);
    doc["camera"]["rate_hz"] = data.rig.camera_rate_hz;
    doc["camera"]["pixel_sigma"] = data.rig.pixel_sigma;
    doc["gyro"]["rate_hz"] = data.rig.gyro_rate_hz;
    doc["gyro"]["noise_density"] = data.rig.gyro_noise_density;
    doc["gyro"]["bias_random_walk"] = data.rig.gyro_bias_random_walk;
  }
  YAML::Node T;
  for (int i = 0; i < 16; ++i) T.push_back(T_B_C.matrix()(i / 4, i % 4));
  T.SetStyle(YAML::EmitterStyle::Flow);
  doc["T_B_C"] = T;
  doc["camera"]["time_offset_s"] = r.time_offset_s;
  YAML::Emitter emitter;
  emitter.SetDoublePrecision(17);
  emitter << doc;
  return fmt::format(
      "# {} with T_B_C's rotation and camera.time_offset_s (image stamp = gyro time + offset) "
      "from `ovo calibrate rig` on {}:\n# {} frame pairs, median rate {:.1f} deg/s, rotation "
      "residual RMS {:.3f} deg, speed correlation {:.3f}; gyro bias [{:.5f}, {:.5f}, {:.5f}] "
      "rad/s; R_B_C moved {:.3f} deg.\n{}\n",
      fs::exists(rig_file) ? "The dataset's rig.yaml" : "A rig.yaml", data.root.string(),
      r.pairs_used, r.median_rate_dps, r.residual_rms_deg, r.correlation, r.gyro_bias_radps.x(),
      r.gyro_bias_radps.y(), r.gyro_bias_radps.z(), r.rotation_change_deg, emitter.c_str());
}

int runCalibrateRig(const RigArgs& args) {
  if (!(args.max_offset_s > 0.0 && args.max_offset_s <= 1.0))
    fail("--max-offset: expected 0 < seconds <= 1, got {}", args.max_offset_s);
  const fs::path out(args.out);
  if (out.has_parent_path() && !fs::is_directory(out.parent_path()))
    fail("--out {}: folder {} not found", args.out, out.parent_path().string());
  if (fs::is_directory(out)) fail("--out {}: is a folder, expected a file name", args.out);
  Config config;
  if (!args.config.empty()) config = Config::load(args.config);
  config.applyOverrides(args.sets);
  const frontend::FrontendOptions frontend_options = frontend::readFrontendOptions(config);
  config.checkAllUsed();
  const io::Dataset data = io::loadDataset(args.dataset);
  if (!data.camera) fail("{}: the dataset has no camera calibration", args.dataset);
  if (data.imu.empty()) fail("{}: the dataset has no gyro samples (imu0/data.csv)", args.dataset);
  if (data.images.size() < 20)
    fail(
        "{}: {} camera frames; the rig calibration needs a sequence with rotation (at least 20 "
        "frames)",
        args.dataset, data.images.size());
  const fs::path rig_file = data.root / "rig.yaml";
  const SE3 T_B_C =
      io::cameraExtrinsics(data.rig, camera::readSensorYamlExtrinsics(data.camera_file), rig_file);

  calib::RigCalibrationOptions options;
  options.max_offset_s = args.max_offset_s;
  options.gyro_noise_density = data.rig.gyro_noise_density;
  calib::RigInput input;
  input.camera = &*data.camera;
  input.frontend = frontend_options;
  input.frame_count = data.images.size();
  input.frame_stamp = [&](std::size_t k) { return data.images[k].t_ns; };
  input.frame_image = [&](std::size_t k) { return io::loadDatasetImage(data, k); };
  input.gyro = data.imu;
  input.R_B_C_prior = T_B_C.linear();
  const calib::RigCalibration result = calib::calibrateRig(input, options);

  SE3 T_B_C_new = T_B_C;
  T_B_C_new.linear() = result.R_B_C;
  const std::string text = rigYaml(data, rig_file, T_B_C_new, result);
  // Written beside the target and renamed: nothing half-written.
  const fs::path staging = out.parent_path() / ("." + out.filename().string() + ".partial");
  {
    std::ofstream f(staging, std::ios::binary);
    if (!f) fail("--out {}: cannot write", args.out);
    f << text;
    if (!f) {
      fs::remove(staging);
      fail("--out {}: write failed", args.out);
    }
  }
  fs::rename(staging, out);
  spdlog::info(
      "calibrate rig: R_B_C changed by {:.3f} deg from the dataset's, time offset {:.2f} ms "
      "({} frame pairs, {:.1f} deg/s median rate); wrote {}",
      result.rotation_change_deg, result.time_offset_s * 1e3, result.pairs_used,
      result.median_rate_dps, args.out);
  return 0;
}

void setupRig(CLI::App& app, const std::shared_ptr<RigArgs>& args) {
  app.add_option("--dataset", args->dataset, "Dataset folder (camera, gyro, rig.yaml)")->required();
  app.add_option("--out", args->out, "rig.yaml to write")->required();
  app.add_option("--config", args->config, "Frontend settings (YAML)");
  app.add_option("--set", args->sets, "Override a frontend key: key.path=value (repeatable)");
  app.add_option("--max-offset", args->max_offset_s,
                 "Largest camera-gyro time offset searched (seconds)")
      ->capture_default_str();
}

CommandRunner setupCalibrate(CLI::App& sub) {
  sub.require_subcommand(1);
  auto camera_args = std::make_shared<CameraArgs>();
  auto rig_args = std::make_shared<RigArgs>();
  CLI::App* camera_app =
      sub.add_subcommand("camera", "Camera intrinsics from checkerboard images or corners");
  setupCamera(*camera_app, camera_args);
  CLI::App* rig_app = sub.add_subcommand(
      "rig", "Camera-to-body rotation and camera-gyro time offset from a sequence with rotation");
  setupRig(*rig_app, rig_args);
  return [=] {
    if (camera_app->parsed()) return runCalibrateCamera(*camera_args);
    return runCalibrateRig(*rig_args);
  };
}

}  // namespace

OVO_REGISTER_COMMAND(calibrate, "Calibrate the camera (checkerboards) or the camera-gyro rig",
                     setupCalibrate);

}  // namespace ovo::app
