#include "camera/camera.hpp"

namespace ovo::camera {

std::optional<Vec3> unproject(const Camera& cam, const Vec2& px) {
  return std::visit([&](const auto& c) { return c.unproject(px); }, cam);
}

std::optional<Vec2> project(const Camera& cam, const Vec3& p_C, Eigen::Matrix<double, 2, 3>* J) {
  return std::visit([&](const auto& c) { return c.project(p_C, J); }, cam);
}

bool isValid(const Camera& cam, const Vec2& px) {
  return std::visit([&](const auto& c) { return c.isValid(px); }, cam);
}

int width(const Camera& cam) {
  return std::visit([](const auto& c) { return c.width(); }, cam);
}

int height(const Camera& cam) {
  return std::visit([](const auto& c) { return c.height(); }, cam);
}

double focalPx(const Camera& cam) {
  return std::visit([](const auto& c) { return c.focalPx(); }, cam);
}

namespace {
struct ModelName {
  std::string operator()(const OcamCamera&) const { return "ocam"; }
  std::string operator()(const KannalaBrandtCamera&) const { return "kannala_brandt"; }
  std::string operator()(const PinholeRadtanCamera&) const { return "pinhole_radtan"; }
};
}  // namespace

std::string modelName(const Camera& cam) { return std::visit(ModelName{}, cam); }

}  // namespace ovo::camera
