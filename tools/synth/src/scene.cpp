#include "scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace pplvo::synth::detail {
namespace {

/// One octave of value noise: a random grid of `cell_px` texels upsampled bicubically.
cv::Mat valueNoise(int w, int h, double cell_px, cv::RNG& rng) {
  const int cell = std::max(2, static_cast<int>(std::lround(cell_px)));
  const int gw = w / cell + 4;
  const int gh = h / cell + 4;
  cv::Mat grid(gh, gw, CV_32FC1);
  rng.fill(grid, cv::RNG::UNIFORM, 0.0f, 1.0f);
  cv::Mat up;
  cv::resize(grid, up, cv::Size(gw * cell, gh * cell), 0, 0, cv::INTER_CUBIC);
  return up(cv::Rect(cell, cell, w, h)).clone();
}

/// Multi-octave value noise normalised to [lo, hi].
cv::Mat fractalNoise(int w, int h, double texels_per_m, cv::RNG& rng, double lo, double hi,
                     double finest_m = 0.015) {
  cv::Mat sum = cv::Mat::zeros(h, w, CV_32FC1);
  const double cells_m[] = {0.30, 0.12, 0.05, finest_m};
  const double weights[] = {0.45, 0.30, 0.25, 0.18};
  for (int k = 0; k < 4; ++k) {
    sum += weights[k] * valueNoise(w, h, cells_m[k] * texels_per_m, rng);
  }
  cv::normalize(sum, sum, lo, hi, cv::NORM_MINMAX);
  return sum;
}

int px(double metres, double texels_per_m) {
  return static_cast<int>(std::lround(metres * texels_per_m));
}

void drawText(cv::Mat& img, cv::Rect area, double s, cv::RNG& rng, double ink_lo, double ink_hi) {
  const double line_h = rng.uniform(0.018, 0.03);
  const double gap = 0.35 * line_h;
  for (double y = area.y + gap * s; y + line_h * s < area.y + area.height;
       y += (line_h + gap) * s) {
    double x = area.x + rng.uniform(0.0, 0.03) * s;
    const double line_end = area.x + area.width * rng.uniform(0.6, 1.0);
    while (true) {
      const double word = rng.uniform(0.012, 0.07) * s;
      if (x + word > line_end) break;
      const double ink = rng.uniform(ink_lo, ink_hi);
      cv::rectangle(img, cv::Point(static_cast<int>(x), static_cast<int>(y)),
                    cv::Point(static_cast<int>(x + word), static_cast<int>(y + 0.65 * line_h * s)),
                    cv::Scalar(ink), cv::FILLED);
      x += word + rng.uniform(0.006, 0.012) * s;
    }
  }
}

void drawBlobs(cv::Mat& img, double s, cv::RNG& rng, double per_m2) {
  const double area_m2 = img.cols * img.rows / (s * s);
  const int n = std::max(3, static_cast<int>(area_m2 * per_m2));
  for (int i = 0; i < n; ++i) {
    const cv::Point c(rng.uniform(0, img.cols), rng.uniform(0, img.rows));
    const double grey = rng.uniform(0.05, 0.95);
    if (rng.uniform(0, 3) == 0) {
      const cv::Size axes(std::max(2, px(rng.uniform(0.01, 0.08), s)),
                          std::max(2, px(rng.uniform(0.01, 0.05), s)));
      cv::ellipse(img, c, axes, rng.uniform(0.0, 180.0), 0, 360, cv::Scalar(grey), cv::FILLED,
                  cv::LINE_AA);
    } else {
      cv::circle(img, c, std::max(2, px(rng.uniform(0.01, 0.07), s)), cv::Scalar(grey), cv::FILLED,
                 cv::LINE_AA);
    }
  }
}

void drawStripes(cv::Mat& img, bool along_u, double s, cv::RNG& rng) {
  const int len = along_u ? img.cols : img.rows;
  int pos = 0;
  while (pos < len) {
    const int width = std::max(2, px(rng.uniform(0.03, 0.18), s));
    const double grey = rng.uniform(0.25, 0.9);
    const cv::Rect r =
        along_u ? cv::Rect(pos, 0, width, img.rows) : cv::Rect(0, pos, img.cols, width);
    img(r & cv::Rect(0, 0, img.cols, img.rows)).setTo(grey);
    pos += width;
    if (rng.uniform(0, 2) == 0) {  // a thin dark separating line
      const int lw = std::max(1, px(0.008, s));
      const cv::Rect l = along_u ? cv::Rect(pos, 0, lw, img.rows) : cv::Rect(0, pos, img.cols, lw);
      img(l & cv::Rect(0, 0, img.cols, img.rows)).setTo(0.1);
      pos += lw;
    }
  }
}

void drawTiles(cv::Mat& img, double tile_m, double grout_m, double s, cv::RNG& rng) {
  const int tile = std::max(4, px(tile_m, s));
  const int grout = std::max(1, px(grout_m, s));
  for (int y = 0; y < img.rows; y += tile) {
    for (int x = 0; x < img.cols; x += tile) {
      const cv::Rect t = cv::Rect(x, y, tile, tile) & cv::Rect(0, 0, img.cols, img.rows);
      cv::Mat roi = img(t);
      roi += rng.uniform(-0.08, 0.08);
      img(cv::Rect(x, y, std::min(grout, img.cols - x), t.height)).setTo(0.15);
      img(cv::Rect(x, y, t.width, std::min(grout, img.rows - y))).setTo(0.15);
    }
  }
}

void drawGrid(cv::Mat& img, double cell_m, double s) {
  const int cell = std::max(4, px(cell_m, s));
  const int lw = std::max(1, px(0.006, s));
  for (int x = cell / 2; x < img.cols; x += cell)
    img(cv::Rect(x, 0, std::min(lw, img.cols - x), img.rows)).setTo(0.12);
  for (int y = cell / 2; y < img.rows; y += cell)
    img(cv::Rect(0, y, img.cols, std::min(lw, img.rows - y))).setTo(0.12);
}

void drawFrame(cv::Mat& img, int border, double grey) {
  const int b = std::min({border, img.cols / 2, img.rows / 2});
  img(cv::Rect(0, 0, img.cols, b)).setTo(grey);
  img(cv::Rect(0, img.rows - b, img.cols, b)).setTo(grey);
  img(cv::Rect(0, 0, b, img.rows)).setTo(grey);
  img(cv::Rect(img.cols - b, 0, b, img.rows)).setTo(grey);
}

cv::Mat makeTexture(TextureStyle style, int w, int h, double s, cv::RNG& rng, double base) {
  cv::Mat img(h, w, CV_32FC1, cv::Scalar(base));
  switch (style) {
    case TextureStyle::kPlain:
      break;
    case TextureStyle::kNoise:
      img = fractalNoise(w, h, s, rng, 0.08, 0.95);
      break;
    case TextureStyle::kBlobs:
      img = fractalNoise(w, h, s, rng, 0.35, 0.75, 0.03);
      drawBlobs(img, s, rng, 260.0);
      break;
    case TextureStyle::kText:
      img.setTo(base);
      drawText(img, cv::Rect(0, 0, w, h), s, rng, 0.05, 0.35);
      break;
    case TextureStyle::kStripesU:
    case TextureStyle::kStripesV:
      drawStripes(img, style == TextureStyle::kStripesU, s, rng);
      break;
    case TextureStyle::kTiles:
      img += fractalNoise(w, h, s, rng, -0.06, 0.06, 0.03);
      drawTiles(img, 0.3, 0.008, s, rng);
      break;
    case TextureStyle::kGrid:
      drawGrid(img, 0.1, s);
      break;
    case TextureStyle::kPoster: {
      img.setTo(rng.uniform(0.6, 0.95));
      const int inner_w = std::max(1, w - 2 * px(0.06, s));
      const int inner_h = std::max(1, h - 2 * px(0.06, s));
      const cv::Point o(px(0.06, s), px(0.06, s));
      const int blocks = rng.uniform(3, 7);
      for (int i = 0; i < blocks; ++i) {
        const int bw = rng.uniform(inner_w / 6 + 1, inner_w / 2 + 2);
        const int bh = rng.uniform(inner_h / 8 + 1, inner_h / 3 + 2);
        const cv::Point p(o.x + rng.uniform(0, std::max(1, inner_w - bw)),
                          o.y + rng.uniform(0, std::max(1, inner_h - bh)));
        cv::rectangle(img, p, p + cv::Point(bw, bh), cv::Scalar(rng.uniform(0.05, 0.95)),
                      cv::FILLED);
      }
      drawText(img, cv::Rect(o.x, o.y + inner_h * 2 / 3, inner_w, inner_h / 3), s, rng, 0.0, 0.2);
      for (int i = 0; i < 4; ++i) {
        cv::circle(img, cv::Point(o.x + rng.uniform(0, inner_w), o.y + rng.uniform(0, inner_h)),
                   px(rng.uniform(0.02, 0.06), s), cv::Scalar(rng.uniform(0.0, 1.0)), cv::FILLED,
                   cv::LINE_AA);
      }
      drawFrame(img, px(0.03, s), 0.08);
      break;
    }
    case TextureStyle::kDoor: {
      img.setTo(0.72);
      img += fractalNoise(w, h, s, rng, -0.03, 0.03, 0.05);
      drawFrame(img, px(0.06, s), 0.35);
      const int m = px(0.15, s);
      const int panel_h = (h - 3 * m) / 2;
      for (int k = 0; k < 2; ++k) {
        const cv::Rect r(m, m + k * (panel_h + m), std::max(1, w - 2 * m), std::max(1, panel_h));
        cv::rectangle(img, r, cv::Scalar(0.3), std::max(1, px(0.012, s)));
      }
      // Handle at about 1 m height (v grows upwards from the floor).
      const cv::Rect handle(w - px(0.16, s), px(0.98, s), px(0.1, s), px(0.03, s));
      img(handle & cv::Rect(0, 0, w, h)).setTo(0.05);
      break;
    }
  }
  cv::Mat out;
  img.convertTo(out, CV_8UC1, 255.0);
  return out;
}

/// Builder that keeps object/surface/texture bookkeeping in one place.
class Builder {
 public:
  Builder(Scene* scene, uint64_t seed) : scene_(scene), seed_(seed) {}

  void room(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const std::string& name,
            const TextureStyle styles[6], const cv::Vec3f tints[6], const double bases[6]) {
    Object o;
    o.kind = Object::Kind::kRoomInside;
    o.lo = lo;
    o.hi = hi;
    addFaces(o, name, styles, tints, bases);
  }

  void box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const std::string& name,
           TextureStyle style, cv::Vec3f tint, double base = 0.7, bool dynamic = false) {
    Object o;
    o.kind = Object::Kind::kBox;
    o.lo = lo;
    o.hi = hi;
    o.dynamic = dynamic;
    TextureStyle styles[6];
    cv::Vec3f tints[6];
    double bases[6];
    for (int k = 0; k < 6; ++k) {
      styles[k] = style;
      tints[k] = tint;
      bases[k] = base;
    }
    addFaces(o, name, styles, tints, bases);
  }

  /// Rectangle on a plane `axis` = `at`, facing `sign`, spanning [lo, hi] in the other axes.
  void rect(int axis, double at, double sign, const Eigen::Vector3d& lo_in,
            const Eigen::Vector3d& hi_in, const std::string& name, TextureStyle style,
            cv::Vec3f tint, double base = 0.8) {
    Object o;
    o.kind = Object::Kind::kRect;
    o.lo = lo_in;
    o.hi = hi_in;
    o.lo[axis] = o.hi[axis] = at;
    o.rect_axis = axis;
    o.rect_sign = sign;
    o.first_surface = static_cast<int>(scene_->surfaces.size());
    scene_->surfaces.push_back(makeSurface(o, name, axis, sign, style, tint, base));
    scene_->objects.push_back(o);
  }

 private:
  void addFaces(Object o, const std::string& name, const TextureStyle styles[6],
                const cv::Vec3f tints[6], const double bases[6]) {
    o.first_surface = static_cast<int>(scene_->surfaces.size());
    static const char* kFace[6] = {"-x", "+x", "-y", "+y", "-z", "+z"};
    for (int f = 0; f < 6; ++f) {
      const int axis = f / 2;
      const double sign = (f % 2) ? 1.0 : -1.0;
      scene_->surfaces.push_back(
          makeSurface(o, name + kFace[f], axis, sign, styles[f], tints[f], bases[f]));
    }
    scene_->objects.push_back(o);
  }

  Surface makeSurface(const Object& o, const std::string& name, int axis, double sign,
                      TextureStyle style, cv::Vec3f tint, double base) {
    Surface s;
    s.name = name;
    s.object = static_cast<int>(scene_->objects.size());
    s.axis = axis;
    s.sign = sign;
    s.ax_u = axis == 0 ? 1 : 0;
    s.ax_v = axis == 2 ? 1 : 2;
    s.tint = tint;
    const double tpm = scene_->texels_per_m;
    const int w = std::max(2, static_cast<int>(std::ceil((o.hi[s.ax_u] - o.lo[s.ax_u]) * tpm)) + 2);
    const int h = std::max(2, static_cast<int>(std::ceil((o.hi[s.ax_v] - o.lo[s.ax_v]) * tpm)) + 2);
    cv::RNG rng(splitmix64(seed_ ^ splitmix64(0x5EED0000ull + scene_->surfaces.size())));
    s.texture = static_cast<int>(scene_->textures.size());
    std::vector<cv::Mat> mips{makeTexture(style, w, h, tpm, rng, base)};
    while (mips.size() < 6 && std::min(mips.back().cols, mips.back().rows) >= 8) {
      cv::Mat down;
      cv::pyrDown(mips.back(), down);
      mips.push_back(down);
    }
    scene_->textures.push_back(std::move(mips));
    return s;
  }

  Scene* scene_;
  uint64_t seed_;
};

const cv::Vec3f kWhite{1.0f, 1.0f, 1.0f};
const cv::Vec3f kWarm{0.82f, 0.93f, 1.0f};  // BGR
const cv::Vec3f kCool{1.0f, 0.95f, 0.85f};
const cv::Vec3f kWood{0.45f, 0.68f, 0.92f};
const cv::Vec3f kGreen{0.55f, 0.9f, 0.6f};
const cv::Vec3f kBlue{0.95f, 0.7f, 0.5f};
const cv::Vec3f kRed{0.5f, 0.55f, 0.95f};
const cv::Vec3f kGrey{0.8f, 0.8f, 0.8f};

}  // namespace

Eigen::Vector3d Scene::dynamicOffset(double t_s) const {
  const double a = dyn_w_rad_s * t_s + dyn_phase_rad;
  // Ellipse of radii 2.0 m (x) and 1.5 m (y) around the room centre, bobbing 0.1 m.
  // Offsets are relative to the time-0 position so that lo/hi store the time-0 box.
  const Eigen::Vector3d c(2.0 * std::cos(a), 1.5 * std::sin(a), 0.1 * std::sin(2.0 * a));
  const Eigen::Vector3d c0(2.0 * std::cos(dyn_phase_rad), 1.5 * std::sin(dyn_phase_rad),
                           0.1 * std::sin(2.0 * dyn_phase_rad));
  return c - c0;
}

Scene buildScene(const std::string& name, uint64_t seed, bool moving_object,
                 double moving_start_rad) {
  if (name != "room" && name != "textureless" && name != "lines") {
    throw std::invalid_argument("unknown synthetic scene '" + name +
                                "' (expected room, textureless or lines)");
  }
  Scene scene;
  scene.dir_light_w.normalize();
  Builder b(&scene, seed);
  const Eigen::Vector3d lo(0, 0, 0), hi(6, 5, 3);
  using V = Eigen::Vector3d;
  using TS = TextureStyle;
  // Posters, whiteboard and door lie in their wall's plane (own surface id, same plane).
  const double kOff = 0.0;

  // Room faces in order -x face (wall x = 6, normal -x), +x (wall x = 0), -y (wall y = 5),
  // +y (wall y = 0), -z (ceiling), +z (floor).
  if (name == "room") {
    const TS styles[6] = {TS::kNoise, TS::kPlain, TS::kBlobs, TS::kPlain, TS::kPlain, TS::kTiles};
    const cv::Vec3f tints[6] = {kWarm, kWhite, kCool, kWarm, kWhite, kWood};
    const double bases[6] = {0.8, 0.82, 0.8, 0.78, 0.9, 0.7};
    b.room(lo, hi, "room", styles, tints, bases);
  } else if (name == "textureless") {
    const TS styles[6] = {TS::kPlain, TS::kPlain, TS::kPlain, TS::kPlain, TS::kPlain, TS::kPlain};
    const cv::Vec3f tints[6] = {kWarm, kWhite, kCool, kWarm, kWhite, kGrey};
    const double bases[6] = {0.8, 0.82, 0.78, 0.8, 0.9, 0.6};
    b.room(lo, hi, "room", styles, tints, bases);
  } else {  // lines
    const TS styles[6] = {TS::kGrid,  TS::kStripesU, TS::kStripesV,
                          TS::kPlain, TS::kPlain,    TS::kTiles};
    const cv::Vec3f tints[6] = {kWarm, kWhite, kCool, kWarm, kWhite, kGrey};
    const double bases[6] = {0.85, 0.8, 0.8, 0.8, 0.9, 0.7};
    b.room(lo, hi, "room", styles, tints, bases);
  }

  if (name == "textureless") {
    b.box(V(5.5, 0.6, 0), V(5.95, 1.8, 1.9), "cabinet", TS::kPlain, kWood, 0.7);
    b.box(V(2.3, 3.6, 0.72), V(3.5, 4.4, 0.76), "table_top", TS::kPlain, kWood, 0.6);
    for (int k = 0; k < 4; ++k) {
      const double x = (k % 2) ? 3.42 : 2.33, y = (k / 2) ? 4.32 : 3.63;
      b.box(V(x, y, 0), V(x + 0.05, y + 0.05, 0.72), "table_leg" + std::to_string(k), TS::kPlain,
            kGrey, 0.3);
    }
    b.box(V(0.3, 4.2, 0), V(0.9, 4.8, 0.6), "box_corner", TS::kPlain, kBlue, 0.7);
    b.box(V(2.3, 0.2, 0), V(3.1, 0.8, 0.5), "box_front", TS::kPlain, kRed, 0.7);
    b.rect(1, kOff, 1.0, V(4.0, 0, 0), V(4.9, 0, 2.05), "door", TS::kPlain, kWood, 0.6);
  } else {
    const bool lines = name == "lines";
    // Wall-mounted rectangles.
    b.rect(0, kOff, 1.0, V(0, 1.0, 1.2), V(0, 2.0, 2.0), "poster_x0", TS::kPoster, kRed);
    b.rect(0, kOff, 1.0, V(0, 2.6, 1.0), V(0, 4.2, 2.0), "whiteboard",
           lines ? TS::kGrid : TS::kText, kWhite, 0.92);
    b.rect(1, kOff, 1.0, V(4.0, 0, 0), V(4.9, 0, 2.05), "door", TS::kDoor, kWood);
    b.rect(1, kOff, 1.0, V(1.2, 0, 1.3), V(2.2, 0, 2.1), "poster_y0", TS::kPoster, kBlue);
    b.rect(1, 5.0 - kOff, -1.0, V(1.5, 0, 1.2), V(2.5, 0, 2.2), "poster_y5a", TS::kPoster, kGreen);
    b.rect(1, 5.0 - kOff, -1.0, V(3.5, 0, 1.4), V(4.3, 0, 2.0), "poster_y5b", TS::kPoster, kWhite);
    b.rect(0, 6.0 - kOff, -1.0, V(0, 3.2, 1.3), V(0, 4.2, 2.0), "poster_x6", TS::kPoster, kCool);
    // Furniture.
    b.box(V(5.5, 0.6, 0), V(5.95, 1.8, 1.9), "cabinet", TS::kStripesV, kWood, 0.7);
    b.box(V(2.3, 3.6, 0.72), V(3.5, 4.4, 0.76), "table_top", lines ? TS::kStripesU : TS::kNoise,
          kWood, 0.6);
    for (int k = 0; k < 4; ++k) {
      const double x = (k % 2) ? 3.42 : 2.33, y = (k / 2) ? 4.32 : 3.63;
      b.box(V(x, y, 0), V(x + 0.05, y + 0.05, 0.72), "table_leg" + std::to_string(k), TS::kPlain,
            kGrey, 0.3);
    }
    b.box(V(2.5, 3.8, 0.76), V(2.9, 4.15, 1.06), "box_on_table", lines ? TS::kGrid : TS::kText,
          kWarm, 0.85);
    b.box(V(0.3, 4.2, 0), V(0.9, 4.8, 0.6), "box_corner", lines ? TS::kStripesU : TS::kBlobs, kBlue,
          0.7);
    b.box(V(0.4, 4.3, 0.6), V(0.8, 4.7, 0.9), "box_stacked", lines ? TS::kGrid : TS::kNoise, kRed,
          0.7);
    b.box(V(0.2, 0.5, 0), V(0.7, 1.1, 0.8), "box_x0", TS::kGrid, kGreen, 0.8);
    b.box(V(2.3, 0.2, 0), V(3.1, 0.8, 0.5), "box_front", lines ? TS::kTiles : TS::kNoise, kRed,
          0.7);
    b.box(V(4.8, 4.5, 0), V(5.8, 4.95, 2.2), "wardrobe", TS::kStripesU, kWood, 0.7);
    b.box(V(4.3, 2.0, 0), V(4.7, 2.4, 0.35), "box_floor", lines ? TS::kGrid : TS::kBlobs, kCool,
          0.7);
  }

  if (moving_object) {
    SplitMix rng(splitmix64(seed ^ 0xD1A3u));
    scene.dyn_phase_rad = moving_start_rad;
    scene.dyn_w_rad_s = rng.uniform(0.3, 0.45);
    const double a = scene.dyn_phase_rad;
    const V c0(3.0 + 2.0 * std::cos(a), 2.4 + 1.5 * std::sin(a), 1.4);
    const V half(0.18, 0.15, 0.13);
    b.box(c0 - half, c0 + half, "moving_box", TS::kBlobs, kRed, 0.7, /*dynamic=*/true);
  }
  return scene;
}

}  // namespace pplvo::synth::detail
