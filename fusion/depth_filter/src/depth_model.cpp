#include "pplvo/depth_filter/depth_model.h"

namespace pplvo::depth_filter {

bool parseDepthModel(const std::string& text, DepthModel* model) {
  if (text == "sensor")
    *model = DepthModel::kSensor;
  else if (text == "cgm")
    *model = DepthModel::kCgm;
  else if (text == "ogm")
    *model = DepthModel::kOgm;
  else
    return false;
  return true;
}

const char* toString(DepthModel model) {
  switch (model) {
    case DepthModel::kSensor:
      return "sensor";
    case DepthModel::kCgm:
      return "cgm";
    case DepthModel::kOgm:
      return "ogm";
  }
  return "?";
}

}  // namespace pplvo::depth_filter
