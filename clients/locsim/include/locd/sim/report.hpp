// What `locsim` prints: one JSON object (--json) or a short human summary, and the plot.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "locd/sdk/feature_map.hpp"
#include "locd/sim/evaluation_report.hpp"
#include "locd/sim/offline_runner.hpp"

namespace locd::sim {

void write_json(std::ostream& out, const RunResult& result);
// What `locsim run` and `live` print at the end: the JSON object (json) or the summary on stdout,
// and with a plot file the plot, named on stderr (json) or stdout.
void report_run(const RunResult& result, const FeatureMap2D& map, bool json, const std::string& plot_file);
void write_summary(std::ostream& out, const RunResult& result);
// Every scored estimate as CSV: time, estimate, truth, errors, the reported (x, y, yaw) covariance,
// NEES and state. Throws std::runtime_error if the file cannot be written.
void write_trace(const std::string& csv_file, const RunResult& result);

// The localization object of evaluation_report.hpp plus the event's kind and distance.
nlohmann::ordered_json localization_json(const StateSummary& localization, const std::optional<SimulatedEvent>& event);
// The state line of evaluation_report.hpp plus the event's line.
void write_localization_summary(std::ostream& out, const StateSummary& localization,
                                const std::optional<SimulatedEvent>& event);

// Draws the map's walls, the truth path (green), the estimates (red), the start, a scale bar and
// a legend to a PNG (OpenCV). Throws std::runtime_error if the file cannot be written.
void plot_run(const std::string& png_file, const FeatureMap2D& map, const RunResult& result);

}  // namespace locd::sim
