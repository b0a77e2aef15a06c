#include "locd/emoi_markov/progress.hpp"

#include <algorithm>
#include <cmath>

namespace locd::emoi {

void ProgressBar::update(double fraction, const std::string& stage) {
  const int percent = static_cast<int>(std::lround(std::clamp(fraction, 0.0, 1.0) * 100.0));
  if (percent == last_percent_ && stage == last_stage_) return;
  last_percent_ = percent;
  last_stage_ = stage;
  const int filled = percent * width_ / 100;
  out_ << "\r[" << std::string(filled, '#') << std::string(width_ - filled, '.') << "] " << percent << "% "
       << stage << "\033[K" << std::flush;
}

void ProgressBar::finish() { out_ << "\n" << std::flush; }

}  // namespace locd::emoi
