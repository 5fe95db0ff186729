// `ovo simulate` with a board scenario (`scene: checkerboard`, e.g. configs/sim/checkerboard.yaml):
// checkerboard views for camera calibration (sim/board_scene.hpp) written as a dataset folder:
// cam0/data/*.png, the true camera in cam0/, and the truth in sim/ (board poses, corner pixels in
// the corner-file format `ovo calibrate camera --corners` reads, the effective scene).
#include <spdlog/spdlog.h>

#include <atomic>

#include "camera/calib_io.hpp"
#include "common/config.hpp"
#include "io/dataset_writer.hpp"
#include "sim/board_scene.hpp"
#include "sim/simulation.hpp"

namespace ovo::app {

int runBoardSimulation(const Config& config, const std::string& out, bool overwrite) {
  const sim::BoardSceneOptions options = sim::readBoardScene(config);
  const camera::Camera cam = camera::loadCamera(options.calibration);
  const std::vector<sim::BoardView> views = sim::boardViews(cam, options);
  io::DatasetWriter writer(out, overwrite);
  spdlog::info(
      "simulate: checkerboard scene, {} views of a {}x{} board ({} m squares), {}x{} "
      "({}), writing {}",
      views.size(), options.cols, options.rows, options.square_m, camera::width(cam),
      camera::height(cam), camera::modelName(cam), out);
  const Timestamp t0 = 1'000'000'000;
  std::string poses = "# image T_C_B row-major 3x4 (board -> camera)\n";
  std::string corners = fmt::format(
      "# image index u v X Y Z: true corner pixels, board coordinates in squares of {} m\n",
      options.square_m);
  for (std::size_t k = 0; k < views.size(); ++k) {
    const Timestamp t = t0 + static_cast<Timestamp>(k) * 1'000'000'000;
    writer.writeImage(t, sim::renderBoardView(cam, options, views[k], static_cast<int>(k)));
    const std::string name = fmt::format("{}.png", t);
    const Eigen::Matrix<double, 3, 4> M = views[k].T_C_B.matrix().topRows<3>();
    poses += name;
    for (int i = 0; i < 12; ++i) poses += fmt::format(" {:.17g}", M(i / 4, i % 4));
    poses += "\n";
    for (std::size_t i = 0; i < views[k].corners_px.size(); ++i)
      corners += fmt::format("{} {} {:.6f} {:.6f} {} {} 0\n", name, i, views[k].corners_px[i].x(),
                             views[k].corners_px[i].y(), i % options.cols, i / options.cols);
  }
  writer.writeCamera(cam, SE3::Identity(), 1.0);
  writer.writeText("sim/board_poses.txt", poses);
  writer.writeText("sim/board_corners.txt", corners);
  writer.writeText("sim/scenario.yaml", sim::boardSceneYaml(options));
  writer.commit();
  spdlog::info("simulate: wrote {} board images to {}", views.size(), out);
  return 0;
}

}  // namespace ovo::app
