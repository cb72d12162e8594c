#include "pplvo/depth_filter/depth_model.h"

#include "pplvo/core/enum_names.h"

namespace pplvo::depth_filter {

namespace {
constexpr EnumName<DepthModel> kDepthModelNames[] = {
    {DepthModel::kSensor, "sensor"}, {DepthModel::kCgm, "cgm"}, {DepthModel::kOgm, "ogm"}};
}  // namespace

bool parseDepthModel(const std::string& text, DepthModel* model) {
  return parseEnum(kDepthModelNames, text, model);
}

const char* toString(DepthModel model) { return enumName(kDepthModelNames, model); }

}  // namespace pplvo::depth_filter
