#include "pplvo/replay/replay_stage.h"

#include <cstring>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include "pplvo/core/enum_names.h"
#include "pplvo/depth_filter_node/depth_filter_node.h"
#include "pplvo/logging/event_log.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/odometry_nodes/estimator_node.h"
#include "pplvo/odometry_nodes/frontend_node.h"

namespace pplvo::replay {

namespace {
constexpr EnumName<Stage> kStageNames[] = {{Stage::kDepthFilter, "depth-filter"},
                                           {Stage::kFrontend, "frontend"},
                                           {Stage::kEstimator, "estimator"},
                                           {Stage::kPipeline, "pipeline"}};
}  // namespace

bool parseStage(const std::string& text, Stage* stage) {
  return parseEnum(kStageNames, text, stage);
}

const char* toString(Stage stage) { return enumName(kStageNames, stage); }

bool ReplayResult::allIdentical() const {
  if (failed || outputs.empty()) return false;
  for (const ChannelComparison& c : outputs) {
    if (!c.allIdentical()) return false;
  }
  return true;
}

std::string ReplayResult::text() const {
  std::ostringstream out;
  if (failed) out << "FAILED: " << error << "\n";
  out << "inputs fed: " << inputs_fed
      << (log_truncated ? " (log truncated: read up to the cut)" : "") << "\n";
  for (const ChannelComparison& c : outputs) {
    out << c.channel << ": recorded " << c.recorded << ", replayed " << c.replayed << ", identical "
        << c.identical;
    if (c.first_mismatch >= 0) out << ", first difference at message " << c.first_mismatch;
    if (c.afterEnd() > 0) out << ", " << c.afterEnd() << " more after the end of the log";
    out << (c.allIdentical() ? "  [same]" : "  [DIFFERENT]") << "\n";
  }
  return out.str();
}

namespace {

/// Collects the raw bytes published on one channel.
class RawRecorder {
 public:
  RawRecorder(lcm::LCM& lcm, const std::string& channel) : lcm_(lcm) {
    sub_ = lcm_.subscribe(channel, &RawRecorder::onMessage, this);
  }
  ~RawRecorder() { lcm_.unsubscribe(sub_); }
  void onMessage(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    const auto* p = static_cast<const uint8_t*>(rbuf->data);
    messages.emplace_back(p, p + rbuf->data_size);
  }
  std::vector<std::vector<uint8_t>> messages;

 private:
  lcm::LCM& lcm_;
  lcm::Subscription* sub_ = nullptr;
};

/// The node of one stage, its inputs and its outputs (default channels).
struct StageUnderTest {
  std::set<std::string> inputs;
  std::vector<std::string> outputs;
  std::unique_ptr<nodes::DepthFilterNode> depth_filter;
  std::unique_ptr<nodes::FrontendNode> frontend;
  std::unique_ptr<nodes::EstimatorNode> estimator;

  /// Publishes what the node computed ahead of its inputs on a worker and holds back until a
  /// later input (the frontend's stage 2D of the next frame, waiting for the previous frame's
  /// fused depth; fusions on the depth filter's worker). pplvo-run publishes it from its idle
  /// loop, so a log that ends there holds it: without this, a cut log replays as DIFFERENT.
  void finishInFlightWork(lcm::LCM& lcm) {
    auto dispatch = [&] {
      while (lcm.handleTimeout(0) > 0) {
      }
    };
    // With several stages one's output is another's input: until nothing moves.
    for (bool moved = true; moved;) {
      moved = false;
      if (frontend && frontend->publishStage2d(true)) {
        dispatch();
        moved = true;
      }
      if (depth_filter) {
        while (depth_filter->fusing() && depth_filter->publishFusions(true)) {
          dispatch();
          moved = true;
        }
      }
    }
  }
};

}  // namespace

std::set<std::string> stageInputChannels(Stage stage) {
  switch (stage) {
    case Stage::kDepthFilter: {
      const nodes::DepthFilterNodeOptions o;
      return {o.rgbd_channel, o.pose_channel};
    }
    case Stage::kFrontend: {
      const nodes::FrontendNodeOptions o;
      return {o.rgbd_channel, o.cgm_channel, o.fused_channel};
    }
    case Stage::kEstimator: {
      const nodes::EstimatorNodeOptions o;
      return {o.features_channel, o.features_3d_channel};
    }
    case Stage::kPipeline:
      return {nodes::DepthFilterNodeOptions{}.rgbd_channel};
  }
  return {};
}

namespace {

StageUnderTest makeStage(Stage stage, const pipeline::PipelineOptions& p, lcm::LCM& lcm) {
  StageUnderTest s;
  s.inputs = stageInputChannels(stage);
  switch (stage) {
    case Stage::kDepthFilter: {
      nodes::DepthFilterNodeOptions o;
      o.filter = p.depth_filter;
      s.outputs = {o.cgm_channel, o.fused_channel};
      s.depth_filter = std::make_unique<nodes::DepthFilterNode>(o, lcm);
      break;
    }
    case Stage::kFrontend: {
      nodes::FrontendNodeOptions o;
      o.frontend = p.frontend;
      s.outputs = {o.features_channel, o.features_3d_channel};
      s.frontend = std::make_unique<nodes::FrontendNode>(o, lcm);
      break;
    }
    case Stage::kEstimator: {
      nodes::EstimatorNodeOptions o;
      o.odometry = p.odometry;
      s.outputs = {o.pose_channel};
      s.estimator = std::make_unique<nodes::EstimatorNode>(o, lcm);
      break;
    }
    case Stage::kPipeline: {
      nodes::DepthFilterNodeOptions d;
      d.filter = p.depth_filter;
      d.filter.overload.backlog = 0;  // one frame at a time: nothing to shed (as pplvo-run)
      nodes::FrontendNodeOptions f;
      f.frontend = p.frontend;
      f.max_unlifted = 0;  // every frame waits for its fused depth (one frame at a time)
      nodes::EstimatorNodeOptions e;
      e.odometry = p.odometry;
      s.outputs = {d.cgm_channel, d.fused_channel, f.features_channel, f.features_3d_channel,
                   e.pose_channel};
      s.depth_filter = std::make_unique<nodes::DepthFilterNode>(d, lcm);
      s.frontend = std::make_unique<nodes::FrontendNode>(f, lcm);
      s.estimator = std::make_unique<nodes::EstimatorNode>(e, lcm);
      break;
    }
  }
  return s;
}

}  // namespace

ReplayResult replayStage(const ReplayOptions& options) {
  ReplayResult result;
  try {
    lcm::LCM lcm("memq://");
    if (!lcm.good()) throw std::runtime_error("cannot open memq:// LCM");
    StageUnderTest stage = makeStage(options.stage, options.pipeline, lcm);
    std::map<std::string, std::unique_ptr<RawRecorder>> replayed;
    std::map<std::string, std::vector<std::vector<uint8_t>>> recorded;
    for (const std::string& c : stage.outputs) {
      replayed[c] = std::make_unique<RawRecorder>(lcm, c);
      recorded[c];
    }
    logging::EventLogReader reader(options.log);  // throws LogReadError naming the file
    const bool whole_pipeline = options.stage == Stage::kPipeline;
    while (auto ev = reader.next()) {
      if (stage.inputs.count(ev->channel)) {
        lcm.publish(ev->channel, ev->data.data(), static_cast<unsigned int>(ev->data.size()));
        ++result.inputs_fed;
        while (lcm.handleTimeout(0) > 0) {
        }
        // The whole pipeline takes each frame to its pose before the next (pplvo-run's
        // --in-flight 1, which gives the same trajectory as any other number in flight).
        if (whole_pipeline) stage.finishInFlightWork(lcm);
      } else if (recorded.count(ev->channel)) {
        recorded[ev->channel].push_back(std::move(ev->data));
      }
    }
    result.log_truncated = reader.truncated();
    stage.finishInFlightWork(lcm);
    for (const std::string& c : stage.outputs) {
      // A channel the recording left out (a compact log's derived channels) has nothing to
      // compare with; the pose is always compared.
      if (whole_pipeline && recorded[c].empty() && c != channels::kPose) continue;
      ChannelComparison cmp;
      cmp.channel = c;
      const auto& want = recorded[c];
      const auto& got = replayed[c]->messages;
      cmp.recorded = static_cast<int64_t>(want.size());
      cmp.replayed = static_cast<int64_t>(got.size());
      for (size_t i = 0; i < std::min(want.size(), got.size()); ++i) {
        if (want[i] == got[i])
          ++cmp.identical;
        else if (cmp.first_mismatch < 0)
          cmp.first_mismatch = static_cast<int64_t>(i);
      }
      if (cmp.first_mismatch < 0 && got.size() < want.size()) {
        cmp.first_mismatch = static_cast<int64_t>(got.size());  // a recorded one never came
      }
      result.outputs.push_back(cmp);
    }
    if (result.inputs_fed == 0) {
      result.failed = true;
      result.error =
          "the log has no message on the inputs of the " + std::string(toString(options.stage));
    }
  } catch (const std::exception& e) {
    result.failed = true;
    result.error = e.what();
  }
  return result;
}

}  // namespace pplvo::replay
