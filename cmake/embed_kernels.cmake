# Writes OUT, a header with one raw string per OpenCL kernel file in KERNELS:
#   inline constexpr const char* kCl_<stem> = R"ovocl(...)ovocl";
set(_content "// Generated from gpu/kernels/*.cl by cmake/embed_kernels.cmake. Do not edit.\n#pragma once\nnamespace ovo::gpu::kernels {\n")
foreach(_k ${KERNELS})
  get_filename_component(_stem ${_k} NAME_WE)
  file(READ ${_k} _src)
  string(APPEND _content "inline constexpr const char* kCl_${_stem} = R\"ovocl(${_src})ovocl\";\n")
endforeach()
string(APPEND _content "}  // namespace ovo::gpu::kernels\n")
file(WRITE ${OUT}.tmp "${_content}")
file(COPY_FILE ${OUT}.tmp ${OUT} ONLY_IF_DIFFERENT)
