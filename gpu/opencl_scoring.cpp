// The OpenCL scoring backend: hypotheses transposed to 9 planes, 16 per work-item
// (gpu/kernels/ransac_score.cl); device buffers grow on demand and are reused across frames.
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
    if (num_hypotheses <= 0) return;
    const int items = (num_hypotheses + kHypothesesPerItem - 1) / kHypothesesPerItem;
    const int stride = items * kHypothesesPerItem;
    planes_.assign(9 * static_cast<std::size_t>(stride), 0.0f);  // padding: E = 0, never inliers
    for (int h = 0; h < num_hypotheses; ++h)
      for (int j = 0; j < 9; ++j) planes_[static_cast<std::size_t>(j) * stride + h] = E[9 * h + j];
    hyp_.reserve(*ctx_, planes_.size() * sizeof(float), CL_MEM_READ_ONLY);
    counts_buf_.reserve(*ctx_, stride * sizeof(int), CL_MEM_WRITE_ONLY);
    clCheck(
        clEnqueueWriteBuffer(queue_.get(), hyp_.get(), CL_FALSE, 0, planes_.size() * sizeof(float),
                             planes_.data(), 0, nullptr, nullptr),
        "clEnqueueWriteBuffer");
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
    const std::size_t global = static_cast<std::size_t>(items);
    clCheck(clEnqueueNDRangeKernel(queue_.get(), kern, 1, nullptr, &global, nullptr, 0, nullptr,
                                   nullptr),
            "clEnqueueNDRangeKernel");
    result_.resize(stride);
    clCheck(clEnqueueReadBuffer(queue_.get(), out, CL_TRUE, 0, stride * sizeof(int), result_.data(),
                                0, nullptr, nullptr),
            "clEnqueueReadBuffer");
    std::copy(result_.begin(), result_.begin() + num_hypotheses, counts);
  }

  void parallelFor(int n, const std::function<void(int, int)>& fn) override {
    hostParallelFor(n, fn);
  }

 private:
  std::shared_ptr<OpenClContext> ctx_;
  ClKernel kernel_;
  ClQueue queue_;
  ClBuffer prev_, cur_, hyp_, counts_buf_;
  std::vector<float> planes_;
  std::vector<int> result_;
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
