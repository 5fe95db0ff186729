#include "gpu/opencl_context.hpp"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <system_error>
#include <vector>

#include "common/error.hpp"

namespace ovo::gpu {

std::string clErrorName(cl_int code) {
  switch (code) {
#define OVO_CL_ERR(name) \
  case name:             \
    return #name;
    OVO_CL_ERR(CL_SUCCESS)
    OVO_CL_ERR(CL_DEVICE_NOT_FOUND)
    OVO_CL_ERR(CL_DEVICE_NOT_AVAILABLE)
    OVO_CL_ERR(CL_COMPILER_NOT_AVAILABLE)
    OVO_CL_ERR(CL_MEM_OBJECT_ALLOCATION_FAILURE)
    OVO_CL_ERR(CL_OUT_OF_RESOURCES)
    OVO_CL_ERR(CL_OUT_OF_HOST_MEMORY)
    OVO_CL_ERR(CL_PROFILING_INFO_NOT_AVAILABLE)
    OVO_CL_ERR(CL_MEM_COPY_OVERLAP)
    OVO_CL_ERR(CL_IMAGE_FORMAT_MISMATCH)
    OVO_CL_ERR(CL_IMAGE_FORMAT_NOT_SUPPORTED)
    OVO_CL_ERR(CL_BUILD_PROGRAM_FAILURE)
    OVO_CL_ERR(CL_MAP_FAILURE)
    OVO_CL_ERR(CL_MISALIGNED_SUB_BUFFER_OFFSET)
    OVO_CL_ERR(CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST)
    OVO_CL_ERR(CL_COMPILE_PROGRAM_FAILURE)
    OVO_CL_ERR(CL_LINKER_NOT_AVAILABLE)
    OVO_CL_ERR(CL_LINK_PROGRAM_FAILURE)
    OVO_CL_ERR(CL_DEVICE_PARTITION_FAILED)
    OVO_CL_ERR(CL_KERNEL_ARG_INFO_NOT_AVAILABLE)
    OVO_CL_ERR(CL_INVALID_VALUE)
    OVO_CL_ERR(CL_INVALID_DEVICE_TYPE)
    OVO_CL_ERR(CL_INVALID_PLATFORM)
    OVO_CL_ERR(CL_INVALID_DEVICE)
    OVO_CL_ERR(CL_INVALID_CONTEXT)
    OVO_CL_ERR(CL_INVALID_QUEUE_PROPERTIES)
    OVO_CL_ERR(CL_INVALID_COMMAND_QUEUE)
    OVO_CL_ERR(CL_INVALID_HOST_PTR)
    OVO_CL_ERR(CL_INVALID_MEM_OBJECT)
    OVO_CL_ERR(CL_INVALID_IMAGE_FORMAT_DESCRIPTOR)
    OVO_CL_ERR(CL_INVALID_IMAGE_SIZE)
    OVO_CL_ERR(CL_INVALID_SAMPLER)
    OVO_CL_ERR(CL_INVALID_BINARY)
    OVO_CL_ERR(CL_INVALID_BUILD_OPTIONS)
    OVO_CL_ERR(CL_INVALID_PROGRAM)
    OVO_CL_ERR(CL_INVALID_PROGRAM_EXECUTABLE)
    OVO_CL_ERR(CL_INVALID_KERNEL_NAME)
    OVO_CL_ERR(CL_INVALID_KERNEL_DEFINITION)
    OVO_CL_ERR(CL_INVALID_KERNEL)
    OVO_CL_ERR(CL_INVALID_ARG_INDEX)
    OVO_CL_ERR(CL_INVALID_ARG_VALUE)
    OVO_CL_ERR(CL_INVALID_ARG_SIZE)
    OVO_CL_ERR(CL_INVALID_KERNEL_ARGS)
    OVO_CL_ERR(CL_INVALID_WORK_DIMENSION)
    OVO_CL_ERR(CL_INVALID_WORK_GROUP_SIZE)
    OVO_CL_ERR(CL_INVALID_WORK_ITEM_SIZE)
    OVO_CL_ERR(CL_INVALID_GLOBAL_OFFSET)
    OVO_CL_ERR(CL_INVALID_EVENT_WAIT_LIST)
    OVO_CL_ERR(CL_INVALID_EVENT)
    OVO_CL_ERR(CL_INVALID_OPERATION)
    OVO_CL_ERR(CL_INVALID_GL_OBJECT)
    OVO_CL_ERR(CL_INVALID_BUFFER_SIZE)
    OVO_CL_ERR(CL_INVALID_MIP_LEVEL)
    OVO_CL_ERR(CL_INVALID_GLOBAL_WORK_SIZE)
    OVO_CL_ERR(CL_INVALID_PROPERTY)
    OVO_CL_ERR(CL_INVALID_IMAGE_DESCRIPTOR)
    OVO_CL_ERR(CL_INVALID_COMPILER_OPTIONS)
    OVO_CL_ERR(CL_INVALID_LINKER_OPTIONS)
    OVO_CL_ERR(CL_INVALID_DEVICE_PARTITION_COUNT)
#undef OVO_CL_ERR
    case -1001:
      return "CL_PLATFORM_NOT_FOUND_KHR";
    default:
      return "CL_UNKNOWN_ERROR(" + std::to_string(code) + ")";
  }
}

void clCheck(cl_int code, const char* call) {
  if (code != CL_SUCCESS) fail("{}: {}", call, clErrorName(code));
}

void ensurePoclCacheDir() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (std::getenv("POCL_CACHE_DIR")) return;
    std::filesystem::path dir;
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
      dir = std::filesystem::path(xdg) / "ovo" / "pocl";
    else
      dir = std::filesystem::temp_directory_path() /
            ("ovo-pocl-" + std::to_string(static_cast<long>(::getuid())));
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (!ec) ::setenv("POCL_CACHE_DIR", dir.c_str(), 0);
  });
}

namespace {

std::string platformString(cl_platform_id p, cl_platform_info what) {
  std::size_t n = 0;
  if (clGetPlatformInfo(p, what, 0, nullptr, &n) != CL_SUCCESS || n == 0) return {};
  std::string s(n, '\0');
  clGetPlatformInfo(p, what, n, s.data(), nullptr);
  while (!s.empty() && s.back() == '\0') s.pop_back();
  return s;
}

std::string deviceString(cl_device_id d, cl_device_info what) {
  std::size_t n = 0;
  if (clGetDeviceInfo(d, what, 0, nullptr, &n) != CL_SUCCESS || n == 0) return {};
  std::string s(n, '\0');
  clGetDeviceInfo(d, what, n, s.data(), nullptr);
  while (!s.empty() && s.back() == '\0') s.pop_back();
  return s;
}

struct Candidate {
  cl_platform_id platform;
  cl_device_id device;
  cl_device_type type;
  std::string platform_name, device_name;
};

int typeRank(cl_device_type t) {
  if (t & CL_DEVICE_TYPE_GPU) return 0;
  if (t & CL_DEVICE_TYPE_ACCELERATOR) return 1;
  return 2;
}

std::vector<Candidate> listDevices() {
  std::vector<Candidate> out;
  cl_uint num_platforms = 0;
  if (clGetPlatformIDs(0, nullptr, &num_platforms) != CL_SUCCESS || num_platforms == 0) return out;
  std::vector<cl_platform_id> platforms(num_platforms);
  clGetPlatformIDs(num_platforms, platforms.data(), nullptr);
  for (cl_platform_id p : platforms) {
    cl_uint num_devices = 0;
    if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, nullptr, &num_devices) != CL_SUCCESS) continue;
    std::vector<cl_device_id> devices(num_devices);
    clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, num_devices, devices.data(), nullptr);
    for (cl_device_id d : devices) {
      cl_bool available = CL_FALSE, compiler = CL_FALSE;
      cl_device_type type = 0;
      clGetDeviceInfo(d, CL_DEVICE_AVAILABLE, sizeof(available), &available, nullptr);
      clGetDeviceInfo(d, CL_DEVICE_COMPILER_AVAILABLE, sizeof(compiler), &compiler, nullptr);
      clGetDeviceInfo(d, CL_DEVICE_TYPE, sizeof(type), &type, nullptr);
      if (!available || !compiler) continue;
      out.push_back(
          {p, d, type, platformString(p, CL_PLATFORM_NAME), deviceString(d, CL_DEVICE_NAME)});
    }
  }
  return out;
}

}  // namespace

std::shared_ptr<OpenClContext> OpenClContext::shared(std::string* reason) {
  static std::mutex mutex;
  static std::shared_ptr<OpenClContext> instance;
  auto say = [&](std::string why) {
    if (reason) *reason = std::move(why);
    return nullptr;
  };
  if (const char* off = std::getenv("OVO_NO_OPENCL"); off && *off && std::string(off) != "0")
    return say("OpenCL disabled by OVO_NO_OPENCL");
  std::lock_guard lock(mutex);
  if (instance) return instance;

  ensurePoclCacheDir();
  std::vector<Candidate> devices = listDevices();
  if (devices.empty())
    return say(
        "no OpenCL platform with an available device (is an ICD such as pocl-opencl-icd "
        "installed, and POCL_CACHE_DIR writable?)");
  const Candidate* chosen = nullptr;
  if (const char* want = std::getenv("OVO_OPENCL_DEVICE"); want && *want) {
    for (const auto& c : devices)
      if (c.device_name.find(want) != std::string::npos) {
        chosen = &c;
        break;
      }
    if (!chosen)
      return say(std::string("no OpenCL device name contains OVO_OPENCL_DEVICE='") + want + "'");
  } else {
    for (const auto& c : devices)
      if (!chosen || typeRank(c.type) < typeRank(chosen->type)) chosen = &c;
  }

  std::shared_ptr<OpenClContext> ctx(new OpenClContext());
  cl_int err = CL_SUCCESS;
  const cl_context_properties props[] = {
      CL_CONTEXT_PLATFORM, reinterpret_cast<cl_context_properties>(chosen->platform), 0};
  ctx->context_ =
      ClContextHandle(clCreateContext(props, 1, &chosen->device, nullptr, nullptr, &err));
  if (err != CL_SUCCESS) return say("clCreateContext: " + clErrorName(err));
  ctx->device_ = chosen->device;
  ctx->device_type_ = chosen->type;
  ctx->platform_name_ = chosen->platform_name;
  ctx->device_name_ = chosen->device_name;
  instance = ctx;
  return instance;
}

OpenClContext::~OpenClContext() {
  programs_.clear();  // programs before the context
}

std::string OpenClContext::deviceTypeName() const {
  if (device_type_ & CL_DEVICE_TYPE_GPU) return "gpu";
  if (device_type_ & CL_DEVICE_TYPE_ACCELERATOR) return "accelerator";
  if (device_type_ & CL_DEVICE_TYPE_CPU) return "cpu";
  return "other";
}

cl_program OpenClContext::program(const std::string& source, const std::string& options) {
  std::lock_guard lock(programs_mutex_);
  auto key = std::make_pair(source, options);
  if (auto it = programs_.find(key); it != programs_.end()) return it->second.get();
  const char* src = source.c_str();
  const std::size_t len = source.size();
  cl_int err = CL_SUCCESS;
  ClProgram prog(clCreateProgramWithSource(context(), 1, &src, &len, &err));
  clCheck(err, "clCreateProgramWithSource");
  // The OpenCL compiler's warnings (PoCL's clang prints "N warnings generated." on stderr) stay
  // out of a normal run (-w); with --verbose they are shown, and the build log is logged.
  const bool verbose = spdlog::get_level() <= spdlog::level::debug;
  const std::string build_options = verbose ? options : options + " -w";
  err = clBuildProgram(prog.get(), 1, &device_, build_options.c_str(), nullptr, nullptr);
  auto buildLog = [&] {
    std::size_t n = 0;
    clGetProgramBuildInfo(prog.get(), device_, CL_PROGRAM_BUILD_LOG, 0, nullptr, &n);
    std::string log(n, '\0');
    if (n) clGetProgramBuildInfo(prog.get(), device_, CL_PROGRAM_BUILD_LOG, n, log.data(), nullptr);
    while (!log.empty() && (log.back() == '\0' || log.back() == '\n')) log.pop_back();
    return log;
  };
  if (err != CL_SUCCESS)
    fail("clBuildProgram: {} (device '{}', options '{}')\n{}", clErrorName(err), device_name_,
         build_options, buildLog());
  if (verbose)
    if (const std::string log = buildLog(); !log.empty())
      spdlog::debug("OpenCL build log (device '{}', options '{}'):\n{}", device_name_,
                    build_options, log);
  cl_program raw = prog.get();
  programs_.emplace(std::move(key), std::move(prog));
  return raw;
}

ClQueue OpenClContext::createQueue() const {
  cl_int err = CL_SUCCESS;
  ClQueue q(clCreateCommandQueue(context(), device_, 0, &err));
  clCheck(err, "clCreateCommandQueue");
  return q;
}

ClKernel OpenClContext::createKernel(cl_program program, const char* name) const {
  cl_int err = CL_SUCCESS;
  ClKernel k(clCreateKernel(program, name, &err));
  clCheck(err, "clCreateKernel");
  return k;
}

void ClBuffer::reserve(const OpenClContext& ctx, std::size_t bytes, cl_mem_flags flags) {
  if (bytes <= capacity_ && mem_) return;
  mem_.reset();
  capacity_ = 0;
  cl_int err = CL_SUCCESS;
  mem_ =
      ClMem(clCreateBuffer(ctx.context(), flags, std::max<std::size_t>(bytes, 64), nullptr, &err));
  clCheck(err, "clCreateBuffer");
  capacity_ = std::max<std::size_t>(bytes, 64);
}

}  // namespace ovo::gpu
