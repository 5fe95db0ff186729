// Fuzz targets for the calibration readers: OCamCalib calib_results.txt, the YAML camera
// calibrations (EuRoC sensor.yaml, Kalibr camchain) with their extrinsics, and rig.yaml
// (extrinsics, noise figures). A camera that loads is used a little (project / unproject), since a
// reader that accepts nonsense shows up there.
#include "camera/calib_io.hpp"
#include "io/dataset.hpp"
#include "tests/fuzz/fuzz_target.hpp"

namespace {

void useCamera(const ovo::camera::Camera& cam) {
  const int w = ovo::camera::width(cam), h = ovo::camera::height(cam);
  for (const ovo::Vec2& px :
       {ovo::Vec2(0.5 * w, 0.5 * h), ovo::Vec2(0, 0), ovo::Vec2(w - 1, h - 1)})
    if (const auto b = ovo::camera::unproject(cam, px)) (void)ovo::camera::project(cam, *b);
  (void)ovo::camera::project(cam, ovo::Vec3(0.1, -0.2, 1.0));
  (void)ovo::camera::project(cam, ovo::Vec3(1.0, 0.0, -0.1));
}

}  // namespace

OVO_FUZZ_TARGET(ocam_calib) {
  const auto file = ovo::fuzz::writeScratch("calib_results.txt", input);
  // The invpol refit (seconds under the sanitizers) runs on one input in 8 and whenever the file
  // has no invpol; the other inputs reach the parser and the model's checks faster.
  ovo::camera::OcamOptions options;
  options.refit_invpol = input.size() % 8 == 0;
  ovo::fuzz::expectOnlyOvoErrors([&] { useCamera(ovo::camera::readOcamCalib(file, options)); });
}

OVO_FUZZ_TARGET(camera_yaml) {
  const auto file = ovo::fuzz::writeScratch("sensor.yaml", input);
  ovo::fuzz::expectOnlyOvoErrors([&] { useCamera(ovo::camera::loadCamera(file)); });
  ovo::fuzz::expectOnlyOvoErrors([&] { (void)ovo::camera::readSensorYamlExtrinsics(file); });
}

OVO_FUZZ_TARGET(rig_yaml) {
  const auto file = ovo::fuzz::writeScratch("rig.yaml", input);
  ovo::fuzz::expectOnlyOvoErrors([&] { (void)ovo::io::readRigYaml(file); });
}
