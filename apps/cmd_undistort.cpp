// `ovo undistort`: OCamCalib-style perspective undistortion (or panoramic unwrapping) of one image,
// reproducing the toolbox's undistortFunctions outputs (camera/undistort.hpp).
#include <spdlog/spdlog.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "apps/command.hpp"
#include "camera/calib_io.hpp"
#include "camera/undistort.hpp"
#include "common/error.hpp"

namespace ovo::app {
namespace {

// The largest panoramic side (and radius) in pixels: 20000 x 20000 floats are 3.2 GB of maps.
constexpr int kMaxSidePx = 20000;

struct UndistortArgs {
  std::string calib, image, out;
  double sf = 4.0;  // perspective scale factor: focal length = width / sf (pixels)
  bool panoramic = false;
  double rmin_px = 20.0, rmax_px = 470.0;  // panoramic radii around the image centre
  int width = 1200, height = 400;          // panoramic output size (pixels)
};

camera::Camera loadForUndistortion(const std::filesystem::path& file) {
  // The toolbox undistorts with the file's own invpol: keep it, so the output matches.
  const camera::Camera cam = camera::loadCamera(file);
  if (std::holds_alternative<camera::OcamCamera>(cam))
    return camera::readOcamCalib(file, {.refit_invpol = false});
  return cam;
}

int runUndistort(const UndistortArgs& args) {
  // A perspective view wider than ~179 deg (sf 1e-2) or narrower than a pixel (sf 1e4) is no view.
  if (!(args.sf >= 1e-2 && args.sf <= 1e4))
    fail("--sf: expected a scale factor in [0.01, 10000], got {}", args.sf);
  const camera::Camera cam = loadForUndistortion(args.calib);
  if (!std::filesystem::exists(args.image)) fail("{}: image file not found", args.image);
  const cv::Mat input = cv::imread(args.image, cv::IMREAD_UNCHANGED);
  if (input.empty()) fail("{}: cannot decode the image", args.image);

  camera::RemapTable table;
  if (args.panoramic) {
    if (!(args.rmin_px >= 0.0 && args.rmax_px > args.rmin_px && args.rmax_px <= kMaxSidePx))
      fail("--rmin/--rmax: expected 0 <= rmin < rmax <= {}, got {} and {}", kMaxSidePx,
           args.rmin_px, args.rmax_px);
    if (args.width <= 0 || args.height <= 0 || args.width > kMaxSidePx || args.height > kMaxSidePx)
      fail("--width/--height: expected a size of 1 to {} pixels a side, got {}x{}", kMaxSidePx,
           args.width, args.height);
    // The unwrapping is centred on the image centre: OCamCalib's (row, col), else the pixel
    // of the optical axis.
    Vec2 centre_uv;
    if (const auto* ocam = std::get_if<camera::OcamCamera>(&cam)) {
      centre_uv = Vec2(ocam->params().center_col, ocam->params().center_row);
    } else {
      centre_uv = *camera::project(cam, Vec3(0, 0, 1));
    }
    table = camera::panoramicUndistortionMap(centre_uv.y(), centre_uv.x(), args.rmin_px,
                                             args.rmax_px, args.width, args.height);
  } else {
    if (input.cols != camera::width(cam) || input.rows != camera::height(cam))
      fail("{} is {}x{} but the calibration {} is for {}x{} images", args.image, input.cols,
           input.rows, args.calib, camera::width(cam), camera::height(cam));
    table = camera::perspectiveUndistortionMap(cam, args.sf);
  }
  const cv::Mat map_u(table.height, table.width, CV_32F, table.map_u.data());
  const cv::Mat map_v(table.height, table.width, CV_32F, table.map_v.data());
  cv::Mat output;
  cv::remap(input, output, map_u, map_v, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  bool written = false;
  try {
    written = cv::imwrite(args.out, output);
  } catch (const cv::Exception& e) {
    fail("{}: cannot write the image ({})", args.out, e.what());
  }
  if (!written) fail("{}: cannot write the image (unknown extension or folder missing?)", args.out);
  spdlog::info("wrote {} ({}x{}, {} view)", args.out, output.cols, output.rows,
               args.panoramic ? "panoramic" : "perspective");
  return 0;
}

CommandRunner setupUndistort(CLI::App& sub) {
  auto args = std::make_shared<UndistortArgs>();
  sub.add_option("--calib", args->calib, "Camera calibration (calib_results.txt, sensor.yaml)")
      ->required();
  sub.add_option("--image", args->image, "Input image")->required();
  sub.add_option("--out", args->out, "Output image")->required();
  sub.add_option("--sf", args->sf, "Perspective scale factor (focal length = width / sf)")
      ->capture_default_str();
  sub.add_flag("--panoramic", args->panoramic, "Panoramic unwrapping instead of perspective");
  sub.add_option("--rmin", args->rmin_px, "Panoramic inner radius (pixels)")->capture_default_str();
  sub.add_option("--rmax", args->rmax_px, "Panoramic outer radius (pixels)")->capture_default_str();
  sub.add_option("--width", args->width, "Panoramic output width (pixels)")->capture_default_str();
  sub.add_option("--height", args->height, "Panoramic output height (pixels)")
      ->capture_default_str();
  return [args] { return runUndistort(*args); };
}

}  // namespace

OVO_REGISTER_COMMAND(undistort, "Undistort a fisheye image as the OCamCalib toolbox does",
                     setupUndistort);

}  // namespace ovo::app
