#include "io/image_decode.hpp"

#include <zlib.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "io/skipped_records.hpp"

namespace ovo::io {
namespace {

using Bytes = std::span<const std::uint8_t>;

template <typename... Args>
[[noreturn]] void refuse(const char* reason, const std::string& name,
                         fmt::format_string<Args...> format, Args&&... args) {
  throw RecordError(reason,
                    fmt::format("{}: {}", name, fmt::format(format, std::forward<Args>(args)...)));
}

std::uint32_t be32(Bytes b, std::size_t at) {
  return (std::uint32_t{b[at]} << 24) | (std::uint32_t{b[at + 1]} << 16) |
         (std::uint32_t{b[at + 2]} << 8) | std::uint32_t{b[at + 3]};
}
std::uint32_t be16(Bytes b, std::size_t at) { return (std::uint32_t{b[at]} << 8) | b[at + 1]; }

constexpr std::uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

// PNG (ISO/IEC 15948): signature, then chunks of length (4, big-endian, < 2^31), type (4
// letters), data, CRC-32 of type and data. IHDR first (13 bytes), at least one IDAT, IEND.
ImageHeader checkPng(Bytes b, const std::string& name) {
  ImageHeader h{"png", 0, 0};
  std::size_t at = sizeof kPngSignature;
  bool ihdr = false, idat = false;
  while (true) {
    if (b.size() - at < 12)
      refuse("decode", name, "truncated PNG: {} bytes, the chunk at byte {} needs at least 12",
             b.size(), at);
    const std::uint32_t length = be32(b, at);
    char type[5] = {static_cast<char>(b[at + 4]), static_cast<char>(b[at + 5]),
                    static_cast<char>(b[at + 6]), static_cast<char>(b[at + 7]), 0};
    for (int i = 0; i < 4; ++i)
      if (!((type[i] >= 'A' && type[i] <= 'Z') || (type[i] >= 'a' && type[i] <= 'z')))
        refuse("decode", name, "corrupt PNG: no chunk type at byte {}", at + 4);
    if (length > 0x7fffffffu || length > b.size() - at - 12)
      refuse("decode", name,
             "truncated PNG: chunk '{}' at byte {} holds {} bytes, the file ends {}", type, at,
             length, length > b.size() - at - 12 ? "before" : "after");
    const std::string_view t(type, 4);
    const std::uint32_t crc = static_cast<std::uint32_t>(
        crc32(crc32(0L, Z_NULL, 0), b.data() + at + 4, static_cast<uInt>(length + 4)));
    if (crc != be32(b, at + 8 + length))
      refuse("decode", name, "corrupt PNG: chunk '{}' at byte {} fails its CRC", type, at);
    if (!ihdr) {
      if (t != "IHDR" || length != 13)
        refuse("decode", name, "corrupt PNG: the first chunk is '{}', expected IHDR", type);
      ihdr = true;
      const std::uint32_t w = be32(b, at + 8), hgt = be32(b, at + 12);
      if (w == 0 || hgt == 0 || w > 0x7fffffffu || hgt > 0x7fffffffu)
        refuse("decode", name, "corrupt PNG: image size {}x{}", w, hgt);
      h.width = static_cast<int>(w);
      h.height = static_cast<int>(hgt);
    } else if (t == "IHDR") {
      refuse("decode", name, "corrupt PNG: a second IHDR at byte {}", at);
    }
    if (t == "IDAT") idat = true;
    at += 12 + length;
    if (t == "IEND") break;
  }
  if (!idat) refuse("decode", name, "corrupt PNG: no image data (IDAT)");
  return h;
}

// JPEG (ITU T.81): SOI, marker segments (FF xx, length >= 2 including itself) up to the first
// frame header SOFn, which gives the size; the file must end with EOI (FF D9), trailing zero
// bytes allowed (some cameras pad). The entropy-coded data between is the decoder's business.
ImageHeader checkJpeg(Bytes b, const std::string& name) {
  ImageHeader h{"jpeg", 0, 0};
  std::size_t end = b.size();
  while (end > 2 && b[end - 1] == 0) --end;
  if (end < 4 || b[end - 2] != 0xFF || b[end - 1] != 0xD9)
    refuse("decode", name, "truncated JPEG: no end marker (FF D9) at the end of its {} bytes",
           b.size());
  std::size_t at = 2;
  while (true) {
    while (at < end && b[at] == 0xFF && at + 1 < end && b[at + 1] == 0xFF) ++at;  // fill bytes
    if (end - at < 4 || b[at] != 0xFF)
      refuse("decode", name, "corrupt JPEG: no marker at byte {}", at);
    const std::uint8_t marker = b[at + 1];
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) {  // segments without a length
      at += 2;
      continue;
    }
    if (marker == 0xD9 || marker == 0xDA)
      refuse("decode", name, "corrupt JPEG: image data before a frame header (SOF)");
    const std::uint32_t length = be16(b, at + 2);
    if (length < 2 || length > end - at - 2)
      refuse("decode", name, "corrupt JPEG: segment FF {:02X} at byte {} holds {} bytes", marker,
             at, length);
    const bool sof =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (length < 8) refuse("decode", name, "corrupt JPEG: short frame header at byte {}", at);
      h.height = static_cast<int>(be16(b, at + 5));
      h.width = static_cast<int>(be16(b, at + 7));
      if (h.width == 0 || h.height == 0)
        refuse("decode", name, "corrupt JPEG: image size {}x{}", h.width, h.height);
      return h;
    }
    at += 2 + length;
  }
}

}  // namespace

ImageHeader checkImageBytes(Bytes bytes, const std::string& name) {
  if (bytes.size() >= sizeof kPngSignature &&
      std::equal(std::begin(kPngSignature), std::end(kPngSignature), bytes.begin()))
    return checkPng(bytes, name);
  if (bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF)
    return checkJpeg(bytes, name);
  const auto starts = [&](std::initializer_list<std::uint8_t> magic) {
    return bytes.size() >= magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin());
  };
  if (starts({'B', 'M'})) return {"bmp", 0, 0};
  if (starts({'I', 'I', 42, 0}) || starts({'M', 'M', 0, 42})) return {"tiff", 0, 0};
  if (bytes.size() >= 2 && bytes[0] == 'P' && bytes[1] >= '1' && bytes[1] <= '6')
    return {"pnm", 0, 0};
  return {"other", 0, 0};
}

namespace {

void checkSize(const std::string& name, int width, int height, const ExpectedSize& expected) {
  if (expected.size.empty() || (width == expected.size.width && height == expected.size.height))
    return;
  if (expected.source.empty())
    refuse("size", name, "the image is {}x{}, expected {}x{}", width, height, expected.size.width,
           expected.size.height);
  refuse("size", name, "the image is {}x{}, but {} is for {}x{} images", width, height,
         expected.source, expected.size.width, expected.size.height);
}

}  // namespace

cv::Mat decodeImageGrey(Bytes bytes, const std::string& name, const ExpectedSize& expected) {
  if (bytes.empty()) refuse("decode", name, "empty file (expected an 8-bit PNG or JPEG)");
  const ImageHeader h = checkImageBytes(bytes, name);
  // Only the formats a camera's images come in go to OpenCV: it picks a decoder by the content,
  // and some of its libraries abort the process on a bad file (GDCM's assert on a DICOM-like
  // file, found by fuzzing).
  if (h.format == "other")
    refuse("decode", name,
           "cannot decode the image (not a PNG, JPEG, BMP, TIFF or PGM/PPM image by its first "
           "bytes)");
  if (h.width > 0) {
    checkSize(name, h.width, h.height, expected);
    if (std::int64_t{h.width} * h.height > kMaxImagePixels)
      refuse("decode", name, "the image is {}x{}, more than ovo decodes ({} pixels)", h.width,
             h.height, kMaxImagePixels);
  }
  cv::Mat image;
  try {
    // cv::Mat over the caller's bytes (imdecode only reads them).
    const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1,
                         const_cast<std::uint8_t*>(bytes.data()));
    image = cv::imdecode(buffer, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    refuse("decode", name, "cannot decode the image ({})", e.what());
  }
  if (image.empty())
    refuse("decode", name,
           "cannot decode the image (expected an 8-bit PNG/JPEG readable by OpenCV)");
  checkSize(name, image.cols, image.rows, expected);
  return image;
}

cv::Mat readImageGrey(const std::filesystem::path& file, const ExpectedSize& expected) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    refuse("missing_file", file.string(), "image file not found");
  std::ifstream in(file, std::ios::binary);
  std::vector<std::uint8_t> bytes;
  if (in) {
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    in.seekg(0, std::ios::beg);
    if (size > 0) {
      bytes.resize(static_cast<std::size_t>(size));
      in.read(reinterpret_cast<char*>(bytes.data()), size);
    }
  }
  if (!in) refuse("missing_file", file.string(), "cannot read the image file");
  return decodeImageGrey(bytes, file.string(), expected);
}

}  // namespace ovo::io
