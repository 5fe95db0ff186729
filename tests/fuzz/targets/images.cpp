// Fuzz target for ovo's image loading path (io/image_decode): the structure checks of PNG and
// JPEG, then OpenCV's decoder, with and without an expected size.
#include "io/image_decode.hpp"
#include "tests/fuzz/fuzz_target.hpp"

OVO_FUZZ_TARGET(image) {
  ovo::fuzz::expectOnlyOvoErrors([&] { (void)ovo::io::decodeImageGrey(input, "fuzz.png"); });
  ovo::fuzz::expectOnlyOvoErrors([&] {
    (void)ovo::io::decodeImageGrey(input, "fuzz.png", {cv::Size(16, 12), "the test"});
  });
}
