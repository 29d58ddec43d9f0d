// How an edge's ceiling (EdgeEvidence::ceiling: upper bounds on its clearance at points of its
// profile's grid) holds its values and its state (EdgeEvidence::ceiling_done). Internal to
// core/merge: the evaluator writes them, the snapshot stores them.
//
// A ceiling is lowered by each witness found (its ends', its probes'): the bound at a point is
// the least over the witnesses, each computed alone, so lowering it by the witnesses found since
// gives what all of them would, bit for bit, and a witness lowered into it is dropped
// (EdgeEvidence::probe_witness holds those not lowered yet).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

namespace hgraph {

// EdgeEvidence::ceiling_done: not computed; computed from every witness found; computed, but
// witnesses found since wait in probe_witness.
inline constexpr int8_t kCeilingNone = 0;
inline constexpr int8_t kCeilingCurrent = 1;
inline constexpr int8_t kCeilingStale = 2;

// The least float at or above c, as a double (infinity above the floats' range; NaN stays NaN):
// a ceiling's values are these, a little looser than the double (2^-24 relative) and still
// upper bounds, so that the snapshot stores them in half the bytes. Rounding is monotone, so a
// rounded ceiling lowered and rounded again is what rounding once would give.
inline double CeilingValue(double c) {
  if (c > std::numeric_limits<float>::max()) return std::numeric_limits<double>::infinity();
  const auto f = static_cast<float>(c);
  if (static_cast<double>(f) >= c || std::isnan(c)) return f;
  return std::nextafter(f, std::numeric_limits<float>::infinity());
}

}  // namespace hgraph
