// The OpenCL scoring backend: hypotheses transposed to 9 planes, 16 per work-item
// (gpu/kernels/ransac_score.cl), launched in chunks that overlap the host's hypothesis
// generation; device buffers grow on demand and are reused across frames.
#include <algorithm>
#include <vector>

#include "common/error.hpp"
#include "gpu/opencl_context.hpp"
#include "gpu/scoring.hpp"
#include "ovo_cl_kernels.hpp"

namespace ovo::gpu {

void hostParallelFor(int n, const std::function<void(int, int)>& fn);

namespace {

constexpr int kHypothesesPerItem = 16;
// Hypotheses per pipelined launch (a multiple of kHypothesesPerItem).
constexpr int kChunk = 512;

class OpenClBackend final : public ScoringBackend {
 public:
  explicit OpenClBackend(std::shared_ptr<OpenClContext> ctx) : ctx_(std::move(ctx)) {
    const std::string options = std::string("-cl-fp32-correctly-rounded-divide-sqrt -DOVO_FMA=") +
                                (cpuScoringUsesFma() ? "1" : "0");
    cl_program program = ctx_->program(kernels::kCl_ransac_score, options);
    kernel_ = ctx_->createKernel(program, "ransac_score16");
    queue_ = ctx_->createQueue();
  }

  std::string_view name() const override { return "opencl"; }

  void setMatches(const MatchesSoA& m) override {
    n_ = m.n;
    const std::size_t bytes = sizeof(float) * 3 * static_cast<std::size_t>(std::max(1, n_));
    prev_.reserve(*ctx_, bytes, CL_MEM_READ_ONLY);
    cur_.reserve(*ctx_, bytes, CL_MEM_READ_ONLY);
    if (n_ > 0) {
      clCheck(clEnqueueWriteBuffer(queue_.get(), prev_.get(), CL_FALSE, 0, bytes, m.prev, 0,
                                   nullptr, nullptr),
              "clEnqueueWriteBuffer");
      clCheck(clEnqueueWriteBuffer(queue_.get(), cur_.get(), CL_FALSE, 0, bytes, m.cur, 0, nullptr,
                                   nullptr),
              "clEnqueueWriteBuffer");
    }
  }

  void score(const float* E, int num_hypotheses, float k, int* counts) override {
    generateAndScore(
        num_hypotheses, [](int, int) {}, const_cast<float*>(E), k, counts);
  }

  // Chunk c is transposed into the 9 planes and its kernel enqueued (non-blocking) before the
  // host generates chunk c + 1, so the device scores while the CPU solves 8-point samples.
  void generateAndScore(int num_hypotheses, const Generator& generate, float* E, float k,
                        int* counts) override {
    if (num_hypotheses <= 0) return;
    const int items = (num_hypotheses + kHypothesesPerItem - 1) / kHypothesesPerItem;
    const int stride = items * kHypothesesPerItem;
    const std::size_t plane_bytes = sizeof(float) * static_cast<std::size_t>(stride);
    if (planes_.size() < 9 * static_cast<std::size_t>(stride))
      planes_.resize(9 * static_cast<std::size_t>(stride));
    hyp_.reserve(*ctx_, 9 * plane_bytes, CL_MEM_READ_ONLY);
    counts_buf_.reserve(*ctx_, plane_bytes, CL_MEM_WRITE_ONLY);
    setArgs(stride, k);
    for (int c0 = 0; c0 < num_hypotheses; c0 += kChunk) {
      const int c1 = std::min(num_hypotheses, c0 + kChunk);
      const int padded_end = std::min(stride, c0 + kChunk);
      hostParallelFor(c1 - c0, [&](int b, int e) {
        generate(c0 + b, c0 + e);
        for (int h = c0 + b; h < c0 + e; ++h)
          for (int j = 0; j < 9; ++j)
            planes_[static_cast<std::size_t>(j) * stride + h] = E[9 * h + j];
      });
      for (int h = c1; h < padded_end; ++h)  // padding: E = 0, never an inlier
        for (int j = 0; j < 9; ++j) planes_[static_cast<std::size_t>(j) * stride + h] = 0.0f;
      // One rectangular write: 9 rows (planes) of this chunk's columns.
      const std::size_t origin[3] = {sizeof(float) * c0, 0, 0};
      const std::size_t region[3] = {sizeof(float) * (padded_end - c0), 9, 1};
      clCheck(clEnqueueWriteBufferRect(queue_.get(), hyp_.get(), CL_FALSE, origin, origin, region,
                                       plane_bytes, 0, plane_bytes, 0, planes_.data(), 0, nullptr,
                                       nullptr),
              "clEnqueueWriteBufferRect");
      const std::size_t offset = c0 / kHypothesesPerItem;
      const std::size_t global = (padded_end - c0) / kHypothesesPerItem;
      clCheck(clEnqueueNDRangeKernel(queue_.get(), kernel_.get(), 1, &offset, &global, nullptr, 0,
                                     nullptr, nullptr),
              "clEnqueueNDRangeKernel");
      clCheck(clFlush(queue_.get()), "clFlush");
    }
    clCheck(clEnqueueReadBuffer(queue_.get(), counts_buf_.get(), CL_TRUE, 0,
                                sizeof(int) * num_hypotheses, counts, 0, nullptr, nullptr),
            "clEnqueueReadBuffer");
  }

  void parallelFor(int n, const std::function<void(int, int)>& fn) override {
    hostParallelFor(n, fn);
  }

 private:
  void setArgs(int stride, float k) {
    const cl_mem hyp = hyp_.get(), prev = prev_.get(), cur = cur_.get(), out = counts_buf_.get();
    const cl_int stride_arg = stride, n_arg = n_;
    const cl_float k_arg = k;
    cl_kernel kern = kernel_.get();
    clCheck(clSetKernelArg(kern, 0, sizeof(cl_mem), &hyp), "clSetKernelArg");
    clCheck(clSetKernelArg(kern, 1, sizeof(cl_int), &stride_arg), "clSetKernelArg");
    clCheck(clSetKernelArg(kern, 2, sizeof(cl_mem), &prev), "clSetKernelArg");
    clCheck(clSetKernelArg(kern, 3, sizeof(cl_mem), &cur), "clSetKernelArg");
    clCheck(clSetKernelArg(kern, 4, sizeof(cl_int), &n_arg), "clSetKernelArg");
    clCheck(clSetKernelArg(kern, 5, sizeof(cl_float), &k_arg), "clSetKernelArg");
    clCheck(clSetKernelArg(kern, 6, sizeof(cl_mem), &out), "clSetKernelArg");
  }

  std::shared_ptr<OpenClContext> ctx_;
  ClKernel kernel_;
  ClQueue queue_;
  ClBuffer prev_, cur_, hyp_, counts_buf_;
  std::vector<float> planes_;
  int n_ = 0;
};

}  // namespace

std::unique_ptr<ScoringBackend> makeOpenClBackend() {
  std::string reason;
  auto ctx = OpenClContext::shared(&reason);
  if (!ctx) fail("ransac.backend=opencl: {}; choose ransac.backend=threads or auto", reason);
  return std::make_unique<OpenClBackend>(std::move(ctx));
}

}  // namespace ovo::gpu
