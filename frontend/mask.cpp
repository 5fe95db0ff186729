#include "frontend/mask.hpp"

#include <opencv2/imgproc.hpp>

namespace ovo::frontend {

cv::Mat buildValidMask(const camera::Camera& cam, int border_px) {
  const int w = camera::width(cam), h = camera::height(cam);
  cv::Mat valid(h, w, CV_8UC1);
  std::visit(
      [&](const auto& model) {
        for (int v = 0; v < h; ++v) {
          auto* row = valid.ptr<std::uint8_t>(v);
          for (int u = 0; u < w; ++u) row[u] = model.isValid(Vec2(u, v)) ? 255 : 0;
        }
      },
      cam);
  if (border_px <= 0) return valid;
  cv::Mat eroded;
  const cv::Mat kernel =
      cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * border_px + 1, 2 * border_px + 1));
  cv::erode(valid, eroded, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  return eroded;
}

std::vector<float> buildBearingTable(const camera::Camera& cam) {
  const int w = camera::width(cam), h = camera::height(cam);
  std::vector<float> table(static_cast<std::size_t>(w) * h * 3, 0.0f);
  std::visit(
      [&](const auto& model) {
        for (int v = 0; v < h; ++v) {
          for (int u = 0; u < w; ++u) {
            const auto b = model.unproject(Vec2(u, v));
            if (!b) continue;
            float* out = table.data() + 3 * (static_cast<std::size_t>(v) * w + u);
            out[0] = static_cast<float>(b->x());
            out[1] = static_cast<float>(b->y());
            out[2] = static_cast<float>(b->z());
          }
        }
      },
      cam);
  return table;
}

}  // namespace ovo::frontend
