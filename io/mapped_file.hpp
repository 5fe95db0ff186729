// A file mapped read-only into memory (POSIX mmap), for the bag readers: random access to a bag of
// any size without reading it all. Bounds are the caller's to check against size().
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>

namespace ovo::io {

class MappedFile {
 public:
  /// Throws ovo::Error naming the file when it cannot be opened or mapped.
  explicit MappedFile(const std::filesystem::path& file);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  std::span<const std::uint8_t> bytes() const { return {data_, size_}; }
  std::size_t size() const { return size_; }

 private:
  const std::uint8_t* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace ovo::io
