// A selftest run's plan: its classes, what each trial is given, and the order of the trials
// (private to gap/; selftest.cc runs the trials, selftest_report.cc sums them up).
#pragma once

#include <string>
#include <vector>

#include "hexsim/gap/selftest.h"

namespace hexsim::gap::internal {

// One run of consecutive trials: a class (`trials` each) or the detection-threshold sweep.
struct Segment {
  std::string cls;  // clean | one_effect | two_effects | out_of_library | dynamics_one_effect | threshold |
                    // beyond_library
  int trials = 0;
};

struct SelftestPlan {
  SelftestOptions o;
  bool real = true;
  DiagnoseOptions selftest_only, every_compass;
  const std::vector<EffectRange>* effects = nullptr;
  std::string channel;
  std::vector<std::string> classes;  // the classes, in their trials' order (threshold not among them)
  std::vector<double> threshold_grid;
  // Trials in index order. Trial i's simulator seed is seed·100003 + i + 1 and its random stream
  // "gap_selftest/i": a class added later goes after the threshold sweep, so every earlier trial
  // keeps its index and draws.
  std::vector<Segment> segments;
  int total() const {
    int n = 0;
    for (const Segment& s : segments) n += s.trials;
    return n;
  }
};

// Where trial `index` sits: its segment and its number k within it.
struct Slot {
  const Segment* segment = nullptr;
  int k = 0;
};
Slot Locate(const SelftestPlan& plan, size_t index);

// The metrics, targets and table from the trials' records, in index order (selftest_report.cc).
SelftestResult SummariseSelftest(const SelftestPlan& plan, std::vector<TrialRecord> outcomes);

}  // namespace hexsim::gap::internal
