#pragma once
/// The 3D stages (features lifted on fused depth) that later frames may still need, and the
/// keyframe observations waiting for theirs. docs/estimator.md, "Poses ahead of the fused
/// depth": the frontend publishes a frame's 3D stage after its pose (the pose moves its fused
/// depth), so frame k+1 is usually posed before frame k's 3D stage arrives; the buffer keeps
/// what arrives until no later frame can use it, whatever the order of arrival.
///
/// A 3D stage is wanted when it is the last posed frame's (the reference of a fallback, or the
/// next keyframe) or when an observation of that frame waits for it (landmark fusion).
///
/// Thread safety: none. One owner (the FrameTracker) uses it from one thread.
#include <cstdint>
#include <deque>
#include <optional>

#include "pplvo/core/features.h"
#include "pplvo/tracking/keyframe_store.h"

namespace pplvo::tracking {

class LiftedStageBuffer {
 public:
  /// Frame `seq` got a pose: its 3D stage is wanted from now on.
  void setLastPosed(int64_t seq) { last_posed_ = seq; }
  /// The last frame given a pose, if any.
  std::optional<int64_t> lastPosed() const { return last_posed_; }

  /// Keeps `observation` until its frame's 3D stage has been fused.
  void addObservation(KeyframeObservation observation);
  /// The oldest observation whose fusion is due: of a frame posed before the last one
  /// (fusion runs one frame behind, so the next frame never waits for it); nullptr if none.
  const KeyframeObservation* dueObservation() const;
  void popObservation() { observations_.pop_front(); }
  /// Drops the waiting observations (the keyframe they refine is being replaced).
  void dropObservations() { observations_.clear(); }

  /// Whether add() would keep the 3D stage of frame `seq` (checked before decoding it).
  bool wants(int64_t seq) const;
  /// Keeps `lifted` when it is wanted (the same frame again replaces it); false otherwise.
  bool add(FrameFeatures lifted);
  /// The kept 3D stage of frame `seq`, or nullptr.
  const FrameFeatures* find(int64_t seq) const;

  /// Drops the 3D stages no later frame can use (call once a frame is posed and the
  /// observations it leaves are settled).
  void prune();

  /// Forgets everything: stages, observations and the last posed frame.
  void clear();
  /// Forgets the stages and observations, keeping the last posed frame.
  void clearStages();

 private:
  std::optional<int64_t> last_posed_;
  std::deque<KeyframeObservation> observations_;  ///< oldest first, at most two
  std::deque<FrameFeatures> stages_;              ///< oldest first
};

}  // namespace pplvo::tracking
