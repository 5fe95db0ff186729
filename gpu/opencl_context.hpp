// A thin OpenCL layer (DESIGN section 5): device choice, program builds cached per context,
// grow-only buffers, and OpenCL errors turned into ovo::Error naming the call and the error.
#pragma once

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>

#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

namespace ovo::gpu {

/// "CL_BUILD_PROGRAM_FAILURE" for -11, "CL_UNKNOWN_ERROR(<code>)" for codes it does not know.
std::string clErrorName(cl_int code);
/// Throws ovo::Error "<call>: <error name>" when code != CL_SUCCESS.
void clCheck(cl_int code, const char* call);

/// PoCL reports no device without a writable cache folder: sets POCL_CACHE_DIR (when unset) to
/// $XDG_CACHE_HOME/ovo/pocl or /tmp/ovo-pocl-<uid>, creating it. Idempotent.
void ensurePoclCacheDir();

/// RAII owner of one OpenCL object (cl_mem, cl_kernel, cl_program, cl_command_queue, cl_context).
template <typename T, cl_int (*Release)(T)>
class ClHandle {
 public:
  ClHandle() = default;
  explicit ClHandle(T h) : h_(h) {}
  ~ClHandle() { reset(); }
  ClHandle(ClHandle&& o) noexcept : h_(std::exchange(o.h_, nullptr)) {}
  ClHandle& operator=(ClHandle&& o) noexcept {
    if (this != &o) {
      reset();
      h_ = std::exchange(o.h_, nullptr);
    }
    return *this;
  }
  ClHandle(const ClHandle&) = delete;
  ClHandle& operator=(const ClHandle&) = delete;
  void reset() {
    if (h_) Release(h_);
    h_ = nullptr;
  }
  T get() const { return h_; }
  explicit operator bool() const { return h_ != nullptr; }

 private:
  T h_ = nullptr;
};
using ClMem = ClHandle<cl_mem, clReleaseMemObject>;
using ClKernel = ClHandle<cl_kernel, clReleaseKernel>;
using ClProgram = ClHandle<cl_program, clReleaseProgram>;
using ClQueue = ClHandle<cl_command_queue, clReleaseCommandQueue>;
using ClContextHandle = ClHandle<cl_context, clReleaseContext>;

/// Sets the kernel's arguments 0, 1, ... to the given values (each passed by its size and
/// address: cl_mem handles, cl_int, cl_float, cl_ulong ...), checking every call.
template <typename... Args>
void setKernelArgs(cl_kernel kernel, const Args&... args) {
  cl_uint index = 0;
  (clCheck(clSetKernelArg(kernel, index++, sizeof(Args), &args), "clSetKernelArg"), ...);
}

/// One OpenCL context on one device, shared by the process; builds programs once per
/// (source, options) and hands out command queues (one per user, so users never share a queue).
class OpenClContext {
 public:
  /// The process-wide context, created on first success. Returns nullptr and sets *reason when
  /// no device is usable (no platform, no device, OVO_NO_OPENCL=1 set). The device is the first
  /// GPU, else accelerator, else CPU device; OVO_OPENCL_DEVICE=<substring> picks by device name.
  static std::shared_ptr<OpenClContext> shared(std::string* reason = nullptr);

  OpenClContext(const OpenClContext&) = delete;
  OpenClContext& operator=(const OpenClContext&) = delete;
  ~OpenClContext();

  cl_context context() const { return context_.get(); }
  cl_device_id device() const { return device_; }
  const std::string& platformName() const { return platform_name_; }
  const std::string& deviceName() const { return device_name_; }
  cl_device_type deviceType() const { return device_type_; }
  /// Device-type word for logs: "gpu", "cpu", "accelerator".
  std::string deviceTypeName() const;

  /// Builds `source` with `options` (cached; thread-safe). Throws ovo::Error
  /// "clBuildProgram: CL_BUILD_PROGRAM_FAILURE" followed by the build log on failure.
  cl_program program(const std::string& source, const std::string& options);
  /// A new in-order command queue on the device.
  ClQueue createQueue() const;
  /// A new kernel object (kernels hold argument state: one per user).
  ClKernel createKernel(cl_program program, const char* name) const;

 private:
  OpenClContext() = default;
  ClContextHandle context_;
  cl_device_id device_ = nullptr;
  cl_device_type device_type_ = 0;
  std::string platform_name_, device_name_;
  std::mutex programs_mutex_;
  std::map<std::pair<std::string, std::string>, ClProgram> programs_;
};

/// A device buffer that grows on demand and is reused across calls (frames).
class ClBuffer {
 public:
  /// Makes sure the buffer holds at least `bytes`; reallocates (contents lost) only when growing.
  void reserve(const OpenClContext& ctx, std::size_t bytes, cl_mem_flags flags);
  cl_mem get() const { return mem_.get(); }
  std::size_t capacity() const { return capacity_; }

 private:
  ClMem mem_;
  std::size_t capacity_ = 0;
};

}  // namespace ovo::gpu
