#include "pplvo/tracking/lifted_stage_buffer.h"

#include <utility>

namespace pplvo::tracking {

void LiftedStageBuffer::addObservation(KeyframeObservation observation) {
  observations_.push_back(std::move(observation));
}

const KeyframeObservation* LiftedStageBuffer::dueObservation() const {
  if (observations_.empty() || !last_posed_ || observations_.front().seq >= *last_posed_) {
    return nullptr;
  }
  return &observations_.front();
}

bool LiftedStageBuffer::wants(int64_t seq) const {
  if (!last_posed_ || seq < 0) return false;
  if (seq == *last_posed_) return true;
  for (const KeyframeObservation& o : observations_) {
    if (o.seq == seq) return true;
  }
  return false;
}

bool LiftedStageBuffer::add(FrameFeatures lifted) {
  if (!wants(lifted.seq)) return false;
  auto it = stages_.begin();
  while (it != stages_.end() && it->seq < lifted.seq) ++it;
  if (it != stages_.end() && it->seq == lifted.seq) {
    *it = std::move(lifted);  // the same frame again: the newer message serves
  } else {
    stages_.insert(it, std::move(lifted));
  }
  return true;
}

const FrameFeatures* LiftedStageBuffer::find(int64_t seq) const {
  for (const FrameFeatures& f : stages_) {
    if (f.seq == seq) return &f;
  }
  return nullptr;
}

void LiftedStageBuffer::prune() {
  for (auto it = stages_.begin(); it != stages_.end();) {
    it = wants(it->seq) ? it + 1 : stages_.erase(it);
  }
}

void LiftedStageBuffer::clear() {
  clearStages();
  last_posed_.reset();
}

void LiftedStageBuffer::clearStages() {
  observations_.clear();
  stages_.clear();
}

}  // namespace pplvo::tracking
