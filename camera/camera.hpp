// The camera models and the runtime choice between them (one std::variant, as Basalt's
// generic_camera). Pixels: Vec2(u, v) = (column, row), origin at the centre of the top-left pixel.
// Bearings/points in the camera frame C: x right, y down, z forward; a fisheye bearing may have z
// <= 0.
//
// Every model has:
//   std::optional<Vec3> unproject(const Vec2& px) const;   // unit bearing; nullopt outside the
//   domain std::optional<Vec2> project(const Vec3& p_C, Eigen::Matrix<double, 2, 3>* d_px_d_p =
//   nullptr) const;
//        // any non-zero p_C; nullopt only where the model cannot map it (pinhole: z <= epsilon;
//        // fisheye: beyond its calibrated field of view). May return pixels outside the image.
//   bool isValid(const Vec2& px) const;   // inside the image and the valid circle / calibrated
//   area int width() const; int height() const; double focalPx() const;               // approx.
//   pixels per radian near the principal point
// Hot loops should visit the variant once (std::visit) or build a bearing look-up table.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <variant>

#include "camera/kannala_brandt_camera.hpp"
#include "camera/ocam_camera.hpp"
#include "camera/pinhole_radtan_camera.hpp"
#include "common/types.hpp"

namespace ovo::camera {

using Camera = std::variant<OcamCamera, KannalaBrandtCamera, PinholeRadtanCamera>;

std::optional<Vec3> unproject(const Camera& cam, const Vec2& px);
std::optional<Vec2> project(const Camera& cam, const Vec3& p_C,
                            Eigen::Matrix<double, 2, 3>* J = nullptr);
bool isValid(const Camera& cam, const Vec2& px);
int width(const Camera& cam);
int height(const Camera& cam);
double focalPx(const Camera& cam);
/// "ocam", "kannala_brandt", "pinhole_radtan".
std::string modelName(const Camera& cam);

}  // namespace ovo::camera
