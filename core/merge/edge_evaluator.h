// The lazy evaluation of a merge's H-Graph edges (docs/design.md, "Evaluation is lazy"): checks
// of edges in parallel, probes of their clearance on the profile's grid, proofs that an edge
// keeps the clearance a search asks of it, scans for contact, and what the search may assume of
// an edge before its check (its bound's input). Everything it learns is written to the edges'
// reports and to the merge's EdgeEvidence. Internal to core/merge.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/common/progress.h"
#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"
#include "core/merge/evidence.h"
#include "core/motion/motion_checker.h"

namespace hgraph {

// A view of one H-Graph and its evidence that evaluates edges; holds no state of its own, so a
// merge makes one whenever it needs it (it stays valid while the graph and evidence live and
// the evidence matches the graph, EdgeEvidence::Grow). Distinct edges may be evaluated by
// distinct threads where a method says so.
class LazyEdgeEvaluator {
 public:
  LazyEdgeEvaluator(const ClearanceChecker& checker, HGraph& graph, EdgeEvidence& evidence,
                    int threads)
      : checker_(&checker), graph_(graph), evidence_(evidence), threads_(threads) {}

  // Checks the edges in parallel for `need` (what an edge's evidence already establishes is not
  // checked again: its valid ends, its samples if it is valid, its known clearances); adds
  // their number to *checked.
  void CheckEdges(const std::vector<int>& edge_ids, EdgeProof need, const std::string& phase,
                  const ProgressCallback& progress, const CancelToken& cancel, int64_t* checked);
  // Brings the edges a lazy search wants one step closer to their exact value under a measure
  // that needs clearance: a probe of the middle of the profile's grid, then of its quarters, its
  // eighths, ..., then the whole profile. Each step tightens the edge's bound (or finds the
  // motion in contact), so an edge that stops being wanted never pays for its profile.
  // An edge with a positive target (a clearance that decides its value, from the search) is
  // proven to keep it or shown not to (ProveClearance), and profiled only if neither holds.
  // With `ceilings`, the probed edges' ceilings are brought up to date in the same parallel loop.
  void RefineClearanceEdges(const std::vector<int>& edge_ids, const std::vector<double>& targets,
                            bool ceilings, const ProgressCallback& progress,
                            const CancelToken& cancel, int64_t* checked);
  // Computes the clearances on the profile grids of the edges in parallel, in pieces of each
  // edge, before their profiles (which reuse them, EdgeCheckRequest::known): the output's few
  // long edges would otherwise keep one thread each busy.
  // Runs other(0) ... other(other_count - 1) in the same parallel loop (work on other edges).
  void ProbeProfileGrids(const std::vector<int>& edge_ids, const CancelToken& cancel,
                         size_t other_count = 0,
                         const std::function<void(size_t)>& other = nullptr);
  // Computes the clearance of every node that lacks one (the lazy bounds use them). Returns how
  // many it computed.
  int64_t ComputeNodeClearances(const CancelToken& cancel);
  // Brings the ceilings of every edge that may still need one up to date, in parallel (rather
  // than one at a time in the search).
  void ComputeCeilings(const CancelToken& cancel);
  // What the search knows of edge e before its check (with its ceilings, if asked).
  EdgeBoundInput BoundInput(int e, bool ceilings);

 private:
  // Decides whether edge e keeps clearance >= target all along: samples its profile's grid where
  // the known clearances (its ends', its probes') do not yet prove it, until they do
  // (ClearanceFloor >= target), or one sample is below the target, or a contact makes the motion
  // invalid. Returns false if only the profile can decide (no grid point left where a proof
  // lacks). Thread safe for distinct edges.
  bool ProveClearance(int e, double target);
  // Once per unchecked edge, before its first probe: a collision check at each probe round's
  // points (ScanFractions), which finds most candidates in contact for no distance query at all.
  // Marks the edge invalid and returns true if one is in contact. Thread safe for distinct edges.
  bool ScanForContact(int e);
  // Probes the next rounds of edge e's grid (RefineClearanceEdges); whether it found a contact.
  // Thread safe for distinct edges.
  bool ProbeNextRound(int e, bool ceilings);
  // Edge e's motion bound (MotionChecker::MotionBound), computed once. Thread safe for distinct
  // edges.
  double MotionBoundOf(int e);
  // Edge e is invalid: a point at t of it is in contact (found for this many distance queries).
  void MarkInContact(int e, double t, int64_t distance_queries);
  // Adds probed clearances to edge e's, kept sorted by t.
  void AddProbes(int e, const std::vector<ClearanceSample>& found,
                 const std::vector<ClearanceWitness>* witnesses = nullptr);
  // Edge e's ceilings (EdgeBoundInput::ceiling), computed when its ends' or probes' witnesses
  // change. Thread safe for distinct edges.
  const std::vector<ClearanceSample>& CeilingOf(int e);

  const ClearanceChecker* checker_;
  HGraph& graph_;
  EdgeEvidence& evidence_;
  int threads_;
};

}  // namespace hgraph
