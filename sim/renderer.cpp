#include "sim/renderer.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <stdexcept>

namespace ovo::sim {

Renderer::Renderer(const camera::Camera& cam, const RenderOptions& options)
    : width_(camera::width(cam)), height_(camera::height(cam)), samples_(options.supersample) {
  const int ss = samples_;
  bearings_.assign(static_cast<std::size_t>(width_) * height_ * ss * ss, Sample{0.f, 0.f, 0.f});
  footprint_.assign(static_cast<std::size_t>(width_) * height_, 0.0f);
  valid_ = cv::Mat::zeros(height_, width_, CV_8U);
  tbb::parallel_for(tbb::blocked_range<int>(0, height_), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v) {
      for (int u = 0; u < width_; ++u) {
        const Vec2 px(u, v);
        if (!camera::isValid(cam, px)) continue;
        const auto centre = camera::unproject(cam, px);
        if (!centre) continue;
        // Angular size of the pixel: mean angle to the half-pixel neighbours in u and v.
        double width_rad = 0.0;
        int count = 0;
        for (const Vec2& step : {Vec2(0.5, 0.0), Vec2(0.0, 0.5)}) {
          const auto a = camera::unproject(cam, px - step);
          const auto b = camera::unproject(cam, px + step);
          if (a && b) {
            width_rad += std::acos(std::clamp(a->dot(*b), -1.0, 1.0));
            ++count;
          }
        }
        if (count == 0) continue;
        const std::size_t idx = static_cast<std::size_t>(v) * width_ + u;
        footprint_[idx] = static_cast<float>(options.footprint_scale * width_rad / count / ss);
        valid_.at<std::uint8_t>(v, u) = 255;
        for (int sy = 0; sy < ss; ++sy) {
          for (int sx = 0; sx < ss; ++sx) {
            const Vec2 sub = px + Vec2((sx + 0.5) / ss - 0.5, (sy + 0.5) / ss - 0.5);
            const auto b = ss == 1 ? centre : camera::unproject(cam, sub);
            if (b) {
              const Vec3 n = b->normalized();
              bearings_[idx * ss * ss + sy * ss + sx] = {float(n.x()), float(n.y()), float(n.z())};
            }
          }
        }
      }
    }
  });
}

void Renderer::renderRow(const VineyardWorld& world, int v, const SE3& T_W_C, double t_s,
                         float* out) const {
  const Mat3 R_W_C = T_W_C.linear();
  const Vec3 o_W = T_W_C.translation();
  const int per_pixel = samples_ * samples_;
  for (int u = 0; u < width_; ++u) {
    const std::size_t idx = static_cast<std::size_t>(v) * width_ + u;
    const float fp = footprint_[idx];
    if (fp <= 0.0f) continue;
    float sum = 0.0f;
    int n = 0;
    for (int s = 0; s < per_pixel; ++s) {
      const Sample& b = bearings_[idx * per_pixel + s];
      if (b.x == 0.f && b.y == 0.f && b.z == 0.f) continue;
      const Vec3 d_W = R_W_C * Vec3(b.x, b.y, b.z);  // unit: the table holds unit bearings
      sum += world.radiance(o_W, d_W, fp, t_s);
      ++n;
    }
    out[u] = n > 0 ? sum / n : 0.0f;
  }
}

cv::Mat Renderer::renderRadiance(const VineyardWorld& world, const SE3& T_W_C, double t_s) const {
  cv::Mat image(height_, width_, CV_32F, cv::Scalar(0.0f));
  tbb::parallel_for(tbb::blocked_range<int>(0, height_, 4),
                    [&](const tbb::blocked_range<int>& rows) {
                      for (int v = rows.begin(); v < rows.end(); ++v)
                        renderRow(world, v, T_W_C, t_s, image.ptr<float>(v));
                    });
  return image;
}

cv::Mat Renderer::renderRadiance(const VineyardWorld& world, const std::vector<SE3>& T_W_C_rows,
                                 const std::vector<double>& t_rows) const {
  if (static_cast<int>(T_W_C_rows.size()) != height_ || static_cast<int>(t_rows.size()) != height_)
    throw std::invalid_argument("Renderer::renderRadiance: one pose and time per row expected");
  cv::Mat image(height_, width_, CV_32F, cv::Scalar(0.0f));
  tbb::parallel_for(tbb::blocked_range<int>(0, height_, 4),
                    [&](const tbb::blocked_range<int>& rows) {
                      for (int v = rows.begin(); v < rows.end(); ++v)
                        renderRow(world, v, T_W_C_rows[v], t_rows[v], image.ptr<float>(v));
                    });
  return image;
}

double Renderer::meanRadiance(const VineyardWorld& world, const SE3& T_W_C, double t_s,
                              int stride) const {
  const int per_pixel = samples_ * samples_;
  double sum = 0.0;
  int n = 0;
  for (int v = stride / 2; v < height_; v += stride)
    for (int u = stride / 2; u < width_; u += stride) {
      const std::size_t idx = static_cast<std::size_t>(v) * width_ + u;
      const float fp = footprint_[idx];
      const Sample& b = bearings_[idx * per_pixel];
      if (fp <= 0.0f || (b.x == 0.f && b.y == 0.f && b.z == 0.f)) continue;
      sum += world.radiance(T_W_C.translation(), T_W_C.linear() * Vec3(b.x, b.y, b.z), fp, t_s);
      ++n;
    }
  return n > 0 ? sum / n : 0.0;
}

}  // namespace ovo::sim
