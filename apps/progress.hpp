// A one-line terminal progress bar (frames, frames per second, time left) on stderr; silent when
// stderr is not a terminal, so logs and CI output stay clean.
#pragma once

#include <chrono>
#include <string>

namespace ovo::app {

class ProgressBar {
 public:
  explicit ProgressBar(std::string label, bool enabled = true);
  /// Redraws at most ~10 times a second; done/total frames.
  void update(int done, int total);
  /// Ends the line (if anything was drawn).
  void finish();
  bool active() const { return active_; }

 private:
  std::string label_;
  bool active_ = false;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace ovo::app
