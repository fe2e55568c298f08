// Checks shared by the HIL tests (Modbus on loopback, CAN on vcan): the run
// log as a table, JSON outputs, and the documented safe state after a trip.
#ifndef KCRIG_TESTS_SUPPORT_HIL_CHECKS_H_
#define KCRIG_TESTS_SUPPORT_HIL_CHECKS_H_

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"

namespace kcrig {

struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  int Column(const std::string& name) const {
    for (size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return static_cast<int>(i);
    }
    return -1;
  }
  double Value(size_t row, const std::string& name) const {
    return std::stod(rows[row][Column(name)]);
  }
};

inline std::vector<std::string> Split(const std::string& line, char separator) {
  std::vector<std::string> out;
  std::stringstream stream(line);
  std::string item;
  while (std::getline(stream, item, separator)) out.push_back(item);
  return out;
}

inline Csv ReadCsv(const std::string& path) {
  Csv csv;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  csv.header = Split(line, ',');
  while (std::getline(in, line)) csv.rows.push_back(Split(line, ','));
  return csv;
}

inline nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// The documented safe state after a trip: exit 3, cause in run.json, the
// log covers every cycle (uniform time, no row missing before the trip),
// the command ramps linearly to zero over safety.ramp_down_time and the
// last row is disabled at zero force.
inline void ExpectSafeStop(int exit_code, const std::string& log_dir,
                           const std::string& cause,
                           const std::string& output) {
  EXPECT_EQ(exit_code, 3) << output;
  EXPECT_NE(output.find("tripped: " + cause), std::string::npos) << output;
  const nlohmann::json sidecar = ReadJson(log_dir + "/run.json");
  EXPECT_FALSE(std::filesystem::exists(log_dir + "/run.csv.partial"));
  EXPECT_EQ(sidecar["hil"]["safety"]["cause"], cause);
  EXPECT_TRUE(sidecar["hil"]["safety"]["tripped"]);
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  ASSERT_GT(csv.rows.size(), 100u);
  EXPECT_EQ(static_cast<long>(csv.rows.size()),
            sidecar["hil"]["cycles"].get<long>() +
                sidecar["hil"]["skipped_cycles"].get<long>());
  for (size_t j = 0; j < csv.rows.size(); ++j) {
    ASSERT_NEAR(csv.Value(j, "t"), j * 1e-3, 1e-9) << "row " << j;
  }
  const double trip_time = sidecar["hil"]["safety"]["trip_time_s"];
  const size_t trip = static_cast<size_t>(std::lround(trip_time / 1e-3));
  ASSERT_LT(trip, csv.rows.size());
  // Until the fault every row is accounted for: fresh, or a counted miss.
  long misses = 0;
  for (size_t j = 0; j < trip; ++j)
    misses += csv.rows[j][csv.Column("fresh")] == "0";
  EXPECT_LE(misses, sidecar["hil"]["rows_without_fresh_sample"].get<long>());
  auto force = [&](size_t j) {
    return std::hypot(csv.Value(j, "Fx_cmd"), csv.Value(j, "Fy_cmd"),
                      csv.Value(j, "Fz_cmd"));
  };
  // From the trip on the command only falls, never below the linear ramp
  // over safety.ramp_down_time (0.5 s) from the trip (the ramp runs on
  // time: after cycles skipped by an overrun, whose rows repeat the last
  // one, it catches up), and reaches zero no sooner than that.
  const double at_trip = force(trip - 1);
  size_t first_zero = csv.rows.size();
  for (size_t j = trip; j < csv.rows.size(); ++j) {
    ASSERT_LE(force(j), force(j - 1) + 1e-6) << "row " << j;
    const double line =
        at_trip * std::max(0.0, 1.0 - static_cast<double>(j - trip + 1) / 500);
    ASSERT_GE(force(j), line - 1e-3) << "row " << j;
    if (force(j) == 0.0 && first_zero == csv.rows.size()) first_zero = j;
  }
  EXPECT_GE(first_zero - trip + 1, 500u);
  EXPECT_EQ(force(csv.rows.size() - 1), 0.0);
  EXPECT_EQ(csv.rows.back()[csv.Column("safety")], "2");
}

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_HIL_CHECKS_H_
