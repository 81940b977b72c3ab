// Wiener deconvolution of a predicted motion blur (issue 12: a blur-aware path from the motion
// the vehicle knows). See internal.h.
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "internal.h"

namespace lander::vision_internal {

cv::Mat wiener_deblur(const cv::Mat& grey, const Eigen::Vector2d& blur_px, double k) {
  CV_Assert(grey.type() == CV_8UC1 && k > 0);
  const double len = blur_px.norm();
  // Pad by the blur's extent (the DFT wraps around: replicated edges keep the wrap from
  // smearing one border into the other) to sizes the DFT is fast at.
  const int mx = static_cast<int>(std::ceil(std::abs(blur_px.x()))) + 8;
  const int my = static_cast<int>(std::ceil(std::abs(blur_px.y()))) + 8;
  const int W = cv::getOptimalDFTSize(grey.cols + 2 * mx);
  const int H = cv::getOptimalDFTSize(grey.rows + 2 * my);
  cv::Mat f;
  grey.convertTo(f, CV_32F);
  cv::Mat padded;
  cv::copyMakeBorder(f, padded, my, H - grey.rows - my, mx, W - grey.cols - mx, cv::BORDER_REPLICATE);
  // The PSF: the segment from -blur/2 to +blur/2 through the origin, sampled at 8 points a
  // pixel with bilinear weights, wrapped around the DFT grid.
  cv::Mat psf = cv::Mat::zeros(H, W, CV_32F);
  const int n = std::max(2, static_cast<int>(std::ceil(8.0 * len)));
  for (int i = 0; i < n; ++i) {
    const double s = (i + 0.5) / n - 0.5;
    const double x = s * blur_px.x(), y = s * blur_px.y();
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    const double w[2][2] = {{(1 - fx) * (1 - fy), fx * (1 - fy)}, {(1 - fx) * fy, fx * fy}};
    for (int dy = 0; dy < 2; ++dy) {
      for (int dx = 0; dx < 2; ++dx) {
        const int px = ((x0 + dx) % W + W) % W, py = ((y0 + dy) % H + H) % H;
        psf.at<float>(py, px) += static_cast<float>(w[dy][dx] / n);
      }
    }
  }
  cv::Mat G, Hf;
  cv::dft(padded, G, cv::DFT_COMPLEX_OUTPUT);
  cv::dft(psf, Hf, cv::DFT_COMPLEX_OUTPUT);
  cv::Mat F(G.size(), G.type());
  const float kf = static_cast<float>(k);
  for (int y = 0; y < G.rows; ++y) {
    const cv::Vec2f* g = G.ptr<cv::Vec2f>(y);
    const cv::Vec2f* h = Hf.ptr<cv::Vec2f>(y);
    cv::Vec2f* out = F.ptr<cv::Vec2f>(y);
    for (int x = 0; x < G.cols; ++x) {
      const float d = h[x][0] * h[x][0] + h[x][1] * h[x][1] + kf;
      // G conj(H) / (|H|^2 + k)
      out[x] = cv::Vec2f((g[x][0] * h[x][0] + g[x][1] * h[x][1]) / d,
                         (g[x][1] * h[x][0] - g[x][0] * h[x][1]) / d);
    }
  }
  cv::Mat restored;
  cv::idft(F, restored, cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  cv::Mat out8;
  restored(cv::Rect(mx, my, grey.cols, grey.rows)).convertTo(out8, CV_8U);  // saturating
  return out8;
}

}  // namespace lander::vision_internal
