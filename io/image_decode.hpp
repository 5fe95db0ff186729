// Decoding an image file's bytes to 8-bit grey through OpenCV without a codec library printing
// on stderr (libpng's "libpng error: Read Error" for a truncated PNG: OpenCV gives no way to
// install libpng's or libjpeg's message handlers). The bytes are checked first: a PNG's chunks
// (lengths, CRCs, IHDR first, IDAT, IEND), a JPEG's markers up to its frame header and its end
// marker. A truncated or damaged file is refused here with a message saying what is wrong, and the
// header's image size is checked before any pixel is decoded, so a corrupt header cannot make the
// decoder allocate gigabytes. Other formats OpenCV reads (PGM, BMP, TIFF, ...) go to it unchecked.
#pragma once

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <span>
#include <string>

namespace ovo::io {

/// The largest image decoded when no size is expected [pixels].
inline constexpr std::int64_t kMaxImagePixels = 64LL << 20;

struct ImageHeader {
  std::string format;  // "png", "jpeg" (checked), "bmp", "tiff", "pnm" (by their magic) or "other"
  int width = 0, height = 0;
};

/// Checks a PNG's or JPEG's structure and returns what its header says; throws a RecordError
/// (reason "decode") naming `name` and what is wrong. BMP, TIFF and PGM/PPM: their format by the
/// magic bytes, size 0; anything else {"other", 0, 0} (decodeImageGrey refuses it).
ImageHeader checkImageBytes(std::span<const std::uint8_t> bytes, const std::string& name);

/// The size an image must have and what says so, for messages ("the camera calibration (FILE)").
struct ExpectedSize {
  cv::Size size;  // empty: any size up to kMaxImagePixels
  std::string source;
};

/// Checks (checkImageBytes) and decodes to 8-bit grey. An expected size is checked against the
/// header before decoding and against the image after (RecordError "size"). Throws a RecordError
/// "decode" when it does not decode.
cv::Mat decodeImageGrey(std::span<const std::uint8_t> bytes, const std::string& name,
                        const ExpectedSize& expected = {});

/// Reads `file` and decodes it (decodeImageGrey); a RecordError "missing_file" when it is not a
/// readable file.
cv::Mat readImageGrey(const std::filesystem::path& file, const ExpectedSize& expected = {});

}  // namespace ovo::io
