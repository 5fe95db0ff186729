// The OpenCL RANSAC backend: hypotheses generated on the device (gpu/kernels/
// ransac_hypotheses.cl, 8 per work-item in double8 lanes) into 9 float planes, scored there
// (gpu/kernels/ransac_score.cl, 16 per work-item), one blocking read of the counts; two launches
// per block and no host work in between. A device without cl_khr_fp64 scores only: the host pool
// generates. Device buffers grow on demand and are reused across frames.
#include <algorithm>
#include <cstring>
#include <vector>

#include "common/error.hpp"
#include "gpu/opencl_context.hpp"
#include "gpu/scoring.hpp"
#include "gpu/thread_pool.hpp"
#include "ovo_cl_kernels.hpp"

namespace ovo::gpu {
namespace {

constexpr int kScorePerItem = 16;    // ransac_score16
constexpr int kGeneratePerItem = 8;  // ransac_hypotheses8
static_assert(kScorePerItem % kGeneratePerItem == 0);

bool deviceHasFp64(cl_device_id device) {
  std::size_t size = 0;
  if (clGetDeviceInfo(device, CL_DEVICE_EXTENSIONS, 0, nullptr, &size) != CL_SUCCESS) return false;
  std::string extensions(size, '\0');
  if (clGetDeviceInfo(device, CL_DEVICE_EXTENSIONS, size, extensions.data(), nullptr) != CL_SUCCESS)
    return false;
  return extensions.find("cl_khr_fp64") != std::string::npos;
}

class OpenClBackend final : public ScoringBackend {
 public:
  explicit OpenClBackend(std::shared_ptr<OpenClContext> ctx) : ctx_(std::move(ctx)) {
    const std::string options = std::string("-cl-fp32-correctly-rounded-divide-sqrt -DOVO_FMA=") +
                                (cpuScoringUsesFma() ? "1" : "0");
    score_kernel_ =
        ctx_->createKernel(ctx_->program(kernels::kCl_ransac_score, options), "ransac_score16");
    if (deviceHasFp64(ctx_->device()))
      generate_kernel_ = ctx_->createKernel(ctx_->program(kernels::kCl_ransac_hypotheses, ""),
                                            "ransac_hypotheses8");
    queue_ = ctx_->createQueue();
  }

  std::string_view name() const override { return "opencl"; }

  void setMatches(const MatchesSoA& m, const BearingsSoA& b) override {
    n_ = m.n;
    bearings_ = b;
    const std::size_t count = 3 * static_cast<std::size_t>(std::max(1, n_));
    prev_.reserve(*ctx_, sizeof(float) * count, CL_MEM_READ_ONLY);
    cur_.reserve(*ctx_, sizeof(float) * count, CL_MEM_READ_ONLY);
    if (n_ > 0) {
      write(prev_, m.prev, sizeof(float) * count);
      write(cur_, m.cur, sizeof(float) * count);
    }
    has_bearings_ = generate_kernel_ && b.n == n_ && n_ >= 8;
    if (has_bearings_) {
      prev_d_.reserve(*ctx_, sizeof(double) * count, CL_MEM_READ_ONLY);
      cur_d_.reserve(*ctx_, sizeof(double) * count, CL_MEM_READ_ONLY);
      write(prev_d_, b.prev, sizeof(double) * count);
      write(cur_d_, b.cur, sizeof(double) * count);
    }
  }

  void score(const float* E, int num_hypotheses, float k, int* counts) override {
    if (num_hypotheses <= 0) return;
    const int stride = reservePlanes(num_hypotheses);
    uploadPlanes(E, num_hypotheses, stride);
    enqueueScore(stride, k);
    readCounts(counts, num_hypotheses);
  }

  void generateAndScore(std::uint64_t seed, int h_begin, int h_end, float k, int* counts) override {
    if (h_end <= h_begin) return;
    const int count = h_end - h_begin;
    const int stride = reservePlanes(count);
    if (has_bearings_) {
      // The host thread only waits (blocking read): the pool's workers are told to sleep so
      // that the device's own threads get the cores.
      ThreadPool::shared().rest();
      enqueueGenerate(seed, h_begin, stride);
    } else {
      host_E_.resize(9 * static_cast<std::size_t>(count));
      parallelForOnPool(count, [&](int b, int e) {
        generateHypothesesCpu(bearings_, seed, h_begin + b, h_begin + e, host_E_.data() + 9 * b);
      });
      uploadPlanes(host_E_.data(), count, stride);
    }
    enqueueScore(stride, k);
    readCounts(counts, count);
  }

  void generate(std::uint64_t seed, int h_begin, int h_end, float* E) override {
    if (h_end <= h_begin) return;
    const int count = h_end - h_begin;
    if (!has_bearings_) {
      parallelForOnPool(count, [&](int b, int e) {
        generateHypothesesCpu(bearings_, seed, h_begin + b, h_begin + e, E + 9 * b);
      });
      return;
    }
    const int stride = reservePlanes(count);
    enqueueGenerate(seed, h_begin, stride);
    planes_.resize(9 * static_cast<std::size_t>(stride));
    clCheck(
        clEnqueueReadBuffer(queue_.get(), planes_buf_.get(), CL_TRUE, 0,
                            sizeof(float) * planes_.size(), planes_.data(), 0, nullptr, nullptr),
        "clEnqueueReadBuffer");
    for (int h = 0; h < count; ++h)
      for (int j = 0; j < 9; ++j)
        E[9 * static_cast<std::size_t>(h) + j] = planes_[static_cast<std::size_t>(j) * stride + h];
  }

  void parallelFor(int n, const std::function<void(int, int)>& fn) override {
    parallelForOnPool(n, fn);
  }

 private:
  void write(const ClBuffer& buf, const void* data, std::size_t bytes) {
    clCheck(clEnqueueWriteBuffer(queue_.get(), buf.get(), CL_FALSE, 0, bytes, data, 0, nullptr,
                                 nullptr),
            "clEnqueueWriteBuffer");
  }

  // Planes of `stride` floats (count rounded up to the score kernel's 16 per work-item).
  int reservePlanes(int count) {
    const int stride = (count + kScorePerItem - 1) / kScorePerItem * kScorePerItem;
    planes_buf_.reserve(*ctx_, sizeof(float) * 9 * static_cast<std::size_t>(stride),
                        CL_MEM_READ_WRITE);
    counts_buf_.reserve(*ctx_, sizeof(cl_int) * static_cast<std::size_t>(stride),
                        CL_MEM_WRITE_ONLY);
    return stride;
  }

  // Host hypotheses transposed into the planes; the padding is E = 0 (never an inlier).
  void uploadPlanes(const float* E, int count, int stride) {
    planes_.assign(9 * static_cast<std::size_t>(stride), 0.0f);
    for (int h = 0; h < count; ++h)
      for (int j = 0; j < 9; ++j)
        planes_[static_cast<std::size_t>(j) * stride + h] = E[9 * static_cast<std::size_t>(h) + j];
    write(planes_buf_, planes_.data(), sizeof(float) * planes_.size());
  }

  // One work-item per work-group: PoCL hands the groups to its threads, and the kernels are
  // vectorised by hand (double8, float16 lanes).
  void launch(const ClKernel& kernel, std::size_t items, const char* what) {
    const std::size_t local = 1;
    clCheck(clEnqueueNDRangeKernel(queue_.get(), kernel.get(), 1, nullptr, &items, &local, 0,
                                   nullptr, nullptr),
            what);
  }

  void enqueueGenerate(std::uint64_t seed, int h_begin, int stride) {
    setKernelArgs(generate_kernel_.get(), prev_d_.get(), cur_d_.get(), cl_int{n_}, cl_ulong{seed},
                  cl_int{h_begin}, planes_buf_.get(), cl_int{stride});
    launch(generate_kernel_, static_cast<std::size_t>(stride / kGeneratePerItem),
           "clEnqueueNDRangeKernel(ransac_hypotheses8)");
  }

  void enqueueScore(int stride, float k) {
    setKernelArgs(score_kernel_.get(), planes_buf_.get(), cl_int{stride}, prev_.get(), cur_.get(),
                  cl_int{n_}, cl_float{k}, counts_buf_.get());
    launch(score_kernel_, static_cast<std::size_t>(stride / kScorePerItem),
           "clEnqueueNDRangeKernel(ransac_score16)");
  }

  void readCounts(int* counts, int count) {
    clCheck(clEnqueueReadBuffer(queue_.get(), counts_buf_.get(), CL_TRUE, 0,
                                sizeof(cl_int) * static_cast<std::size_t>(count), counts, 0,
                                nullptr, nullptr),
            "clEnqueueReadBuffer");
  }

  std::shared_ptr<OpenClContext> ctx_;
  ClKernel score_kernel_, generate_kernel_;
  ClQueue queue_;
  ClBuffer prev_, cur_, prev_d_, cur_d_, planes_buf_, counts_buf_;
  std::vector<float> planes_, host_E_;
  BearingsSoA bearings_;
  bool has_bearings_ = false;
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
