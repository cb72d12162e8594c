#include "pplvo/eval/pose_records.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <pplvo_msgs/pose_t.hpp>

#include "pplvo/logging/event_log.h"
#include "pplvo/msgs/convert_pose.h"

namespace pplvo {
namespace eval {
namespace {

double stampSeconds(const std::string& text, double fps) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0') return std::numeric_limits<double>::quiet_NaN();
  return fps > 0 ? v / fps : v;
}

}  // namespace

std::vector<RelativePoseRecord> relativePoseRecords(const std::vector<FramePose>& poses,
                                                    double fps) {
  std::vector<RelativePoseRecord> out;
  for (size_t k = 1; k < poses.size(); ++k) {
    const FramePose& p = poses[k];
    if (p.status == TrackingStatus::kFirstFrame) continue;
    RelativePoseRecord r;
    r.stamp_text = p.stamp;
    r.prev_stamp_text = poses[k - 1].stamp;
    r.stamp_s = stampSeconds(r.stamp_text, fps);
    r.prev_stamp_s = stampSeconds(r.prev_stamp_text, fps);
    r.status = static_cast<int>(p.status);
    r.T_prev_curr = p.T_prev_curr;
    r.covariance = p.rel_covariance;
    out.push_back(r);
  }
  return out;
}

bool isLcmEventLog(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char magic[4] = {0, 0, 0, 0};
  in.read(reinterpret_cast<char*>(magic), 4);
  return in.gcount() == 4 && magic[0] == 0xED && magic[1] == 0xA1 && magic[2] == 0xDA &&
         magic[3] == 0x01;
}

PoseLogReadResult readPoseLog(const std::string& path, const std::string& channel) {
  PoseLogReadResult res;
  try {
    logging::EventLogReader reader(path);
    while (auto ev = reader.next()) {
      if (ev->channel != channel) continue;
      pplvo_msgs::pose_t msg;
      if (msg.decode(ev->data.data(), 0, static_cast<int>(ev->data.size())) < 0) {
        ++res.invalid_messages;
        continue;
      }
      try {
        FramePose p = msgs::fromMsg(msg);
        res.poses.push_back(std::move(p));
      } catch (const std::exception&) {
        ++res.invalid_messages;
      }
    }
    res.truncated = reader.truncated();
  } catch (const std::exception& e) {
    res.error = path + ": " + e.what();
    return res;
  }
  std::stable_sort(res.poses.begin(), res.poses.end(),
                   [](const FramePose& a, const FramePose& b) { return a.seq < b.seq; });
  res.ok = true;
  return res;
}

}  // namespace eval
}  // namespace pplvo
