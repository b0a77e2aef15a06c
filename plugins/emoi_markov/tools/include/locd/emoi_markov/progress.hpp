// A text progress bar for long precomputes ([#####.....]  42% stage), redrawn in place.
#pragma once

#include <ostream>
#include <string>

namespace locd::emoi {

class ProgressBar {
 public:
  explicit ProgressBar(std::ostream& out, int width = 40) : out_(out), width_(width) {}
  void update(double fraction, const std::string& stage);
  void finish();

 private:
  std::ostream& out_;
  int width_;
  int last_percent_ = -1;
  std::string last_stage_;
};

}  // namespace locd::emoi
