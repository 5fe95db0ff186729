// ovo's image reader in front of OpenCV: PNG and JPEG are checked before decoding, BMP, TIFF and
// PGM/PPM go through by their magic bytes, anything else is refused before OpenCV picks a decoder
// by the content (GDCM aborted the process on a DICOM-like file: fuzz_image).
#include "io/image_decode.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "io/skipped_records.hpp"

namespace ovo::io {
namespace {

std::vector<std::uint8_t> encoded(const std::string& ext, const cv::Mat& image) {
  std::vector<std::uint8_t> bytes;
  EXPECT_TRUE(cv::imencode(ext, image, bytes)) << ext;
  return bytes;
}

TEST(ImageDecode, TheCameraFormatsDecodeAndOthersAreRefusedBeforeOpenCv) {
  cv::Mat grey(8, 12, CV_8UC1);
  for (int r = 0; r < grey.rows; ++r)
    for (int c = 0; c < grey.cols; ++c)
      grey.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(20 * r + c);
  for (const std::string ext : {".png", ".bmp", ".tiff", ".pgm"}) {
    const cv::Mat out = decodeImageGrey(encoded(ext, grey), "x" + ext);
    ASSERT_EQ(out.size(), grey.size()) << ext;
    EXPECT_EQ(cv::norm(out, grey, cv::NORM_INF), 0.0) << ext;
  }
  EXPECT_EQ(decodeImageGrey(encoded(".jpg", grey), "x.jpg").size(), grey.size());
  // A DICOM preamble ("DICM" at byte 128) with PNG bytes inside: refused, never decoded.
  std::vector<std::uint8_t> dicom(132, 'y');
  dicom[128] = 'D', dicom[129] = 'I', dicom[130] = 'C', dicom[131] = 'M';
  try {
    decodeImageGrey(dicom, "frame_17.png");
    ADD_FAILURE() << "no error";
  } catch (const RecordError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("frame_17.png"), std::string::npos) << msg;
    EXPECT_NE(msg.find("not a PNG, JPEG"), std::string::npos) << msg;
  }
  EXPECT_EQ(checkImageBytes(encoded(".bmp", grey), "x").format, "bmp");
  EXPECT_EQ(checkImageBytes(dicom, "x").format, "other");
}

}  // namespace
}  // namespace ovo::io
