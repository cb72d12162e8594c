#pragma once
/// Which stages of the depth filter run (the paper's comparison of sensor model, C-GM, O-GM).
#include <string>

namespace pplvo::depth_filter {

/// sensor: stage 1 only (variance from the sensor model); cgm: stages 1-2; ogm: all three.
enum class DepthModel { kSensor, kCgm, kOgm };

/// Parses "sensor", "cgm", "ogm"; returns false otherwise.
bool parseDepthModel(const std::string& text, DepthModel* model);
const char* toString(DepthModel model);

}  // namespace pplvo::depth_filter
