#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <set>
#include <sstream>

#include "pplvo/dataset/dataset.h"

namespace fs = std::filesystem;
using namespace pplvo::dataset;

namespace {

std::string sharedData() {
  const char* env = std::getenv("PPLVO_SHARED_DATA");
  return env ? env : "../shared/data";
}

/// A scratch folder removed at the end of the test.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) {
    path = fs::temp_directory_path() /
           ("pplvo_test_dataset_" + std::to_string(::getpid()) + "_" + name);
    fs::remove_all(path);
    fs::create_directories(path / "rgb");
    fs::create_directories(path / "depth");
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string str() const { return path.string(); }
};

void writeText(const fs::path& p, const std::string& text) {
  std::ofstream out(p);
  out << text;
}

/// Writes a small colour PNG and a 16-bit depth PNG whose values encode `tag`.
void writeImages(const fs::path& dir, const std::string& rgb_rel, const std::string& depth_rel,
                 int tag) {
  if (!rgb_rel.empty()) {
    cv::Mat bgr(6, 8, CV_8UC3, cv::Scalar(tag % 256, 10, 20));
    ASSERT_TRUE(cv::imwrite((dir / rgb_rel).string(), bgr));
  }
  if (!depth_rel.empty()) {
    cv::Mat d(6, 8, CV_16UC1, cv::Scalar(1000 + tag));
    ASSERT_TRUE(cv::imwrite((dir / depth_rel).string(), d));
  }
}

void writeCalibXml(const fs::path& p) {
  writeText(p,
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n"
            "<RGB_intrinsic_params type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols>"
            "<dt>d</dt><data>\n 10. 0 4.\n 0\n 11. 3. 0 0 1</data></RGB_intrinsic_params>\n"
            "<RGB_distortion_coefficients type_id=\"opencv-matrix\"><rows>1</rows><cols>5</cols>"
            "<dt>d</dt><data>0 0\n 0 0\n 0</data></RGB_distortion_coefficients>\n"
            "</opencv_storage>\n");
}

}  // namespace

TEST(StampText, ExactMicroseconds) {
  EXPECT_EQ(*stampTextToUtime("1341845688.561749"), 1341845688561749LL);
  EXPECT_EQ(*stampTextToUtime("12"), 12000000LL);
  EXPECT_EQ(*stampTextToUtime("12.5"), 12500000LL);
  EXPECT_EQ(*stampTextToUtime("0.0000015"), 2LL);  // rounded half up
  EXPECT_FALSE(stampTextToUtime("abc").has_value());
  EXPECT_FALSE(stampTextToUtime("1.2.3").has_value());
  EXPECT_FALSE(stampTextToUtime("").has_value());
}

TEST(Associate, GreedyOneToOneLikeTumAssociatePy) {
  // b[0] is within the window of a[0] and a[1]; a[1] is closer still to b[1], so it takes
  // b[1] and leaves b[0] to a[0] (one-to-one, greedy by difference).
  const std::vector<double> a = {1.000, 1.030, 1.060, 2.000};
  const std::vector<double> b = {1.019, 1.031, 1.075, 5.0};
  const auto m = associateStamps(a, b, 0.02);
  // candidates: (a0,b0)=0.019, (a1,b0)=0.011, (a1,b1)=0.001, (a2,b1)=0.029x, (a2,b2)=0.015
  // greedy: (a1,b1) 0.001, (a1,b0) taken-a, (a2,b2) 0.015, (a0,b0) 0.019.
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0], std::make_pair(size_t(0), size_t(0)));
  EXPECT_EQ(m[1], std::make_pair(size_t(1), size_t(1)));
  EXPECT_EQ(m[2], std::make_pair(size_t(2), size_t(2)));
  // Strict window: exactly 0.02 apart is not a match (associate.py uses <).
  EXPECT_TRUE(associateStamps({1.0}, {1.5}, 0.02).empty());
}

TEST(Associate, TumStyleFolderWithJitterAndAbsentFiles) {
  TempDir t("tum");
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.008, 0.008);
  std::ostringstream rgb, depth;
  rgb << "# color images\n# timestamp filename\n";
  depth << "# depth maps\n# timestamp filename\n";
  int expected = 0;
  std::vector<std::string> expected_stamps;
  for (int i = 0; i < 20; ++i) {
    char ts[64], td[64];
    std::snprintf(ts, sizeof ts, "%.6f", 100.0 + i / 30.0);
    std::snprintf(td, sizeof td, "%.6f", 100.0 + i / 30.0 + jitter(rng));
    const std::string rp = std::string("rgb/") + ts + ".png";
    const std::string dp = std::string("depth/") + td + ".png";
    rgb << ts << " " << rp << "\n";
    depth << td << " " << dp << "\n";
    // Frame 5: depth absent; frame 9: colour absent. Extra depth lines listing absent files.
    writeImages(t.path, i == 9 ? "" : rp, i == 5 ? "" : dp, i);
    if (i != 5 && i != 9) {
      ++expected;
      expected_stamps.push_back(ts);
    }
    depth << std::fixed << (100.0 + i / 30.0 + 0.015) << " depth/absent_" << i << ".png\n";
  }
  writeText(t.path / "rgb.txt", rgb.str());
  writeText(t.path / "depth.txt", depth.str());
  const DatasetIndex idx = buildIndex(t.str());
  EXPECT_EQ(idx.summary.source, "rgb.txt+depth.txt");
  EXPECT_EQ(idx.summary.listed, 20);
  EXPECT_EQ(idx.summary.listed_depth, 40);
  EXPECT_EQ(idx.summary.missing_rgb_files, 1);
  EXPECT_EQ(idx.summary.missing_depth_files, 21);
  EXPECT_EQ(idx.summary.unassociated_rgb, 1);  // frame 5 has no depth within 20 ms
  EXPECT_FALSE(idx.summary.index_stamps);
  ASSERT_EQ(static_cast<int>(idx.entries.size()), expected);
  for (size_t k = 0; k < idx.entries.size(); ++k) {
    EXPECT_EQ(idx.entries[k].stamp_text, expected_stamps[k]);  // verbatim, sorted by rgb stamp
    EXPECT_EQ(idx.entries[k].utime, *stampTextToUtime(expected_stamps[k]));
    // Each colour image got the depth map written with the same tag.
    const std::string rgb_name = fs::path(idx.entries[k].rgb_path).filename().string();
    EXPECT_NE(idx.entries[k].depth_path.find("depth/"), std::string::npos);
    EXPECT_EQ(idx.entries[k].depth_path.find("absent"), std::string::npos) << rgb_name;
  }
  EXPECT_NE(idx.summary.text().find("21 missing depth"), std::string::npos) << idx.summary.text();
}

TEST(Associate, AssociationsFileBothColumnOrders) {
  for (bool depth_first : {false, true}) {
    TempDir t(depth_first ? "assoc_df" : "assoc_rf");
    std::ostringstream a;
    a << "# comment line\n";
    for (int i = 0; i < 5; ++i) {
      const std::string ts = "200." + std::to_string(10 + i);
      const std::string td = "200." + std::to_string(20 + i);
      const std::string rp = "rgb/" + std::to_string(i) + ".png";
      const std::string dp = "depth/" + std::to_string(i) + ".png";
      writeImages(t.path, rp, i == 3 ? "" : dp, i);
      if (depth_first) {
        a << td << " " << dp << " " << ts << " " << rp << "\n";
      } else {
        a << ts << " " << rp << " " << td << " " << dp << "\n";
      }
    }
    a << "garbage line\n";
    writeText(t.path / "associations.txt", a.str());
    const DatasetIndex idx = buildIndex(t.str());
    EXPECT_EQ(idx.summary.source, "associations.txt");
    EXPECT_EQ(idx.summary.column_order, depth_first ? "depth-first" : "rgb-first");
    EXPECT_EQ(idx.summary.listed, 5);
    EXPECT_EQ(idx.summary.malformed_lines, 1);
    EXPECT_EQ(idx.summary.missing_depth_files, 1);
    ASSERT_EQ(idx.entries.size(), 4u);
    EXPECT_EQ(idx.entries[0].stamp_text, "200.10");
    EXPECT_EQ(idx.entries[0].depth_stamp_text, "200.20");
    EXPECT_EQ(idx.entries[0].utime, 200100000);
    EXPECT_EQ(idx.entries[0].depth_utime, 200200000);  // the depth image's own instant
    EXPECT_NE(idx.entries[0].rgb_path.find("rgb/0.png"), std::string::npos);
    EXPECT_NE(idx.entries[0].depth_path.find("depth/0.png"), std::string::npos);
    EXPECT_EQ(idx.entries[3].stamp_text, "200.14");
  }
}

TEST(Associate, UnsortedAndDuplicateStampsAreSortedAndReported) {
  TempDir t("assoc_unsorted");
  // Listed order 3 1 2 2' 0 1': two lines out of order (1 after 3, 0 after 2), stamps 1 and 2
  // twice (the first listed of each is kept).
  const std::vector<std::pair<int, int>> lines = {{3, 0}, {1, 1}, {2, 2}, {2, 3}, {0, 4}, {1, 5}};
  std::ostringstream a;
  for (const auto& [stamp, file] : lines) {
    const std::string rp = "rgb/" + std::to_string(file) + ".png";
    const std::string dp = "depth/" + std::to_string(file) + ".png";
    writeImages(t.path, rp, dp, file);
    a << "300." << stamp << " " << rp << " 300." << stamp << " " << dp << "\n";
  }
  writeText(t.path / "associations.txt", a.str());
  const DatasetIndex idx = buildIndex(t.str());
  EXPECT_EQ(idx.summary.listed, 6);
  EXPECT_EQ(idx.summary.out_of_order, 2);
  EXPECT_EQ(idx.summary.duplicate_stamps, 2);
  EXPECT_EQ(idx.summary.first_duplicate, "300.1");  // in stamp order
  ASSERT_EQ(idx.entries.size(), 4u);
  const std::vector<std::string> files = {"rgb/4.png", "rgb/1.png", "rgb/2.png", "rgb/0.png"};
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(idx.entries[k].stamp_text, "300." + std::to_string(k));
    EXPECT_NE(idx.entries[k].rgb_path.find(files[k]), std::string::npos) << k;
  }
  const std::string text = idx.summary.text();
  EXPECT_NE(text.find("2 lines out of stamp order (sorted)"), std::string::npos) << text;
  EXPECT_NE(text.find("2 duplicate stamps dropped (first: 300.1)"), std::string::npos) << text;

  // rgb.txt + depth.txt: the same rule.
  TempDir u("rgb_txt_duplicates");
  std::ostringstream rgb, depth;
  for (const auto& [stamp, file] : lines) {
    const std::string rp = "rgb/" + std::to_string(file) + ".png";
    const std::string dp = "depth/" + std::to_string(file) + ".png";
    writeImages(u.path, rp, dp, file);
    rgb << "400." << stamp << " " << rp << "\n";
    depth << "400." << stamp << "1 " << dp << "\n";
  }
  writeText(u.path / "rgb.txt", rgb.str());
  writeText(u.path / "depth.txt", depth.str());
  const DatasetIndex idx2 = buildIndex(u.str());
  EXPECT_EQ(idx2.summary.out_of_order, 2);
  EXPECT_EQ(idx2.summary.duplicate_stamps, 2);
  ASSERT_EQ(idx2.entries.size(), 4u);
  for (size_t k = 0; k < 4; ++k) EXPECT_EQ(idx2.entries[k].stamp_text, "400." + std::to_string(k));
}

TEST(Associate, IntegerStampsAreFrameIndices) {
  TempDir t("icl");
  std::ostringstream a;
  for (int i = 0; i < 4; ++i) {
    const std::string rp = "rgb/" + std::to_string(i) + ".png";
    const std::string dp = "depth/" + std::to_string(i) + ".png";
    writeImages(t.path, rp, dp, i);
    a << i << " " << dp << " " << i << " " << rp << "\n";
  }
  writeText(t.path / "associations.txt", a.str());
  const DatasetIndex idx = buildIndex(t.str());
  EXPECT_TRUE(idx.summary.index_stamps);
  EXPECT_DOUBLE_EQ(idx.summary.index_frame_rate_hz, 30.0);
  ASSERT_EQ(idx.entries.size(), 4u);
  EXPECT_EQ(idx.entries[3].stamp_text, "3");
  EXPECT_EQ(idx.entries[3].utime, 100000);  // 3 / 30 Hz
  EXPECT_EQ(idx.entries[3].depth_utime, 100000);
  DatasetOptions opt;
  opt.index_frame_rate_hz = 10.0;
  EXPECT_EQ(buildIndex(t.str(), opt).entries[3].utime, 300000);
  // Stamps that are integral but 2 apart are not frame indices (step must be 1).
  TempDir t2("notindex");
  std::ostringstream b;
  for (int i = 0; i < 3; ++i) {
    const std::string rp = "rgb/" + std::to_string(i) + ".png";
    const std::string dp = "depth/" + std::to_string(i) + ".png";
    writeImages(t2.path, rp, dp, i);
    b << 2 * i << " " << rp << " " << 2 * i << " " << dp << "\n";
  }
  writeText(t2.path / "associations.txt", b.str());
  const DatasetIndex idx2 = buildIndex(t2.str());
  EXPECT_FALSE(idx2.summary.index_stamps);
  EXPECT_EQ(idx2.entries[2].utime, 4000000);
}

TEST(Dataset, MissingFolderAndIndex) {
  EXPECT_THROW(buildIndex("/nonexistent/pplvo_dataset"), DatasetError);
  TempDir t("empty");
  try {
    buildIndex(t.str());
    FAIL() << "expected DatasetError";
  } catch (const DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find("associations.txt"), std::string::npos);
  }
  // A folder with an index but no camera file.
  writeImages(t.path, "rgb/0.png", "depth/0.png", 0);
  writeText(t.path / "associations.txt", "1.0 rgb/0.png 1.0 depth/0.png\n");
  try {
    Dataset::open(t.str());
    FAIL() << "expected DatasetError";
  } catch (const DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find("calib_params.xml"), std::string::npos) << e.what();
  }
  // With a calib_params.xml (matrix data broken over lines) it opens; size from the frame.
  writeCalibXml(t.path / "calib_params.xml");
  const Dataset ds = Dataset::open(t.str());
  EXPECT_DOUBLE_EQ(ds.camera().camera.fx, 10.0);
  EXPECT_DOUBLE_EQ(ds.camera().camera.fy, 11.0);
  EXPECT_DOUBLE_EQ(ds.camera().camera.cx, 4.0);
  EXPECT_DOUBLE_EQ(ds.camera().camera.cy, 3.0);
  EXPECT_EQ(ds.camera().camera.width, 8);
  EXPECT_EQ(ds.camera().camera.height, 6);
}

TEST(SharedData, IclLivingRoomHas251FramesFromAssociations) {
  const std::string dir = sharedData() + "/icl_living_room_kt0_short";
  const Dataset ds = Dataset::open(dir);
  const auto& s = ds.index().summary;
  EXPECT_EQ(s.source, "associations.txt");
  EXPECT_EQ(s.column_order, "depth-first");
  EXPECT_EQ(ds.size(), 251u);
  EXPECT_TRUE(s.index_stamps);
  EXPECT_EQ(ds.entry(0).stamp_text, "0");
  EXPECT_EQ(ds.entry(250).stamp_text, "250");
  EXPECT_EQ(ds.entry(30).utime, 1000000);
  EXPECT_NE(ds.entry(7).rgb_path.find("rgb/7.png"), std::string::npos);
  EXPECT_NE(ds.entry(7).depth_path.find("depth/7.png"), std::string::npos);
  EXPECT_EQ(ds.camera().camera.width, 640);
  EXPECT_EQ(ds.camera().camera.height, 480);
  // rgb.txt lists the full trajectory; only associations.txt describes the excerpt.
  std::ifstream rgb(dir + "/rgb.txt");
  const IndexFile listed = parseIndexFile(rgb);
  EXPECT_GT(listed.entries.size(), 1500u);  // 0..1508 as distributed
}

TEST(SharedData, TumSittingStaticMatchesDirectoryListingAndRule) {
  const std::string dir = sharedData() + "/tum_fr3_sitting_static_short";
  // Independent expectation: image files present on disk (directory listing), restricted to
  // those the index files list, associated by the 20 ms rule with a simple quadratic search.
  auto stampsIn = [&](const std::string& sub, const std::string& list) {
    std::set<std::string> listed;
    std::ifstream in(dir + "/" + list);
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ss(line);
      std::string t, p;
      ss >> t >> p;
      listed.insert(p);
    }
    std::vector<std::pair<double, std::string>> out;
    for (const auto& f : fs::directory_iterator(dir + "/" + sub)) {
      const std::string rel = sub + "/" + f.path().filename().string();
      if (listed.count(rel)) out.emplace_back(std::stod(f.path().stem().string()), rel);
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  const auto rgb = stampsIn("rgb", "rgb.txt");
  const auto depth = stampsIn("depth", "depth.txt");
  std::vector<std::tuple<double, size_t, size_t>> cand;
  for (size_t i = 0; i < rgb.size(); ++i) {
    for (size_t j = 0; j < depth.size(); ++j) {
      const double d = std::abs(rgb[i].first - depth[j].first);
      if (d < 0.02) cand.emplace_back(d, i, j);
    }
  }
  std::sort(cand.begin(), cand.end());
  std::set<size_t> ua, ub;
  std::set<std::string> expected_rgb;
  for (const auto& [d, i, j] : cand) {
    if (ua.count(i) || ub.count(j)) continue;
    ua.insert(i);
    ub.insert(j);
    expected_rgb.insert(rgb[i].second);
  }
  const Dataset ds = Dataset::open(dir);
  EXPECT_EQ(ds.size(), expected_rgb.size());
  EXPECT_GE(ds.size(), 140u);
  EXPECT_LE(ds.size(), 150u);
  std::set<std::string> got;
  for (const auto& e : ds.index().entries) {
    got.insert("rgb/" + fs::path(e.rgb_path).filename().string());
    EXPECT_NE(e.stamp_text.find('.'), std::string::npos);
  }
  EXPECT_EQ(got, expected_rgb);
  const auto& s = ds.index().summary;
  EXPECT_EQ(s.source, "rgb.txt+depth.txt");
  EXPECT_FALSE(s.index_stamps);
  EXPECT_GT(s.missing_depth_files, 0);  // depth.txt lists absent files
  // The excerpt holds one colour image that rgb.txt does not list; the summary says so.
  const size_t on_disk =
      std::distance(fs::directory_iterator(dir + "/rgb"), fs::directory_iterator());
  EXPECT_EQ(s.unlisted_rgb_files, static_cast<int>(on_disk - rgb.size()));
  EXPECT_EQ(ds.entry(0).utime, *stampTextToUtime(ds.entry(0).stamp_text));
  EXPECT_EQ(ds.camera().camera.width, 640);
}

TEST(Camera, CalibParamsXmlOfBothSharedFolders) {
  const DatasetCamera icl =
      loadCalibParamsXml(sharedData() + "/icl_living_room_kt0_short/calib_params.xml");
  EXPECT_DOUBLE_EQ(icl.camera.fx, 481.20);
  EXPECT_DOUBLE_EQ(icl.camera.fy, -480.0);  // mirrored model, sign kept
  EXPECT_DOUBLE_EQ(icl.camera.cx, 319.50);
  EXPECT_DOUBLE_EQ(icl.camera.cy, 239.50);
  EXPECT_DOUBLE_EQ(icl.depth_scale, 5000.0);
  const DatasetCamera tum =
      loadCalibParamsXml(sharedData() + "/tum_fr3_sitting_static_short/calib_params.xml");
  EXPECT_DOUBLE_EQ(tum.camera.fx, 535.4);
  EXPECT_DOUBLE_EQ(tum.camera.fy, 539.2);
  EXPECT_DOUBLE_EQ(tum.camera.cx, 320.1);
  EXPECT_DOUBLE_EQ(tum.camera.cy, 247.6);
  for (double d : tum.camera.distortion) EXPECT_EQ(d, 0.0);
  EXPECT_THROW(loadCalibParamsXml("/nonexistent/calib_params.xml"), DatasetError);
  TempDir t("badxml");
  writeText(t.path / "bad.xml", "<?xml version=\"1.0\"?>\n<opencv_storage><x>1</x>");
  EXPECT_THROW(loadCalibParamsXml((t.path / "bad.xml").string()), DatasetError);
  writeText(t.path / "nok.xml", "<?xml version=\"1.0\"?>\n<opencv_storage></opencv_storage>\n");
  try {
    loadCalibParamsXml((t.path / "nok.xml").string());
    FAIL();
  } catch (const DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find("RGB_intrinsic_params"), std::string::npos);
  }
}

// Found by tests/fuzz/fuzz_camera_file: a calib_params.xml whose header holds NUL bytes made
// OpenCV 4.6's FileStorage dereference a null pointer (SEGV in FileStorage::Impl::open). The
// reader rejects files with NUL bytes before FileStorage sees them.
TEST(Camera, CalibParamsXmlWithNulBytesIsAnError) {
  static const char kInput[] =
      "\074\077\170\155\154\040\166\145\162\163\151\157\156\075\000\000\000\000\000\000\000\000\000"
      "\000"
      "\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000"
      "\000"
      "\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000"
      "\000"
      "\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000"
      "\000"
      "\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\042\061\056\060"
      "\042"
      "\077\076\015\012\074\157\160\145\156\143\166\137\163\164\157\162\141\147\145\076\015\012\074"
      "\122"
      "\107\102\137\151\156\164\162\151\156\163\151\143\137\160\141\162\141\155\163\040\164\171\160"
      "\145"
      "\137\151\144\075\042\157\160\145\156\143\166\055\155\141\164\162\151\170\042\076\015\012\040"
      "\040"
      "\074\162\157\167\163\076\063\074\057\162\157\167\163\076\015\012\040\040\074\143\157\154\163"
      "\076"
      "\063\074\057\143\157\154\163\076\015\012\040\040\074\144\164\076\144\074\057\144\164\076\015"
      "\012"
      "\040\040\074\144\141\164\141\076\015\012\040\040\040\040\065\063\065\056\064\040\060\056\040"
      "\063"
      "\062\060\056\061\040\060\056\015\012\040\040\040\040\065\063\071\056\062\040\062\064\067\056"
      "\066"
      "\040\060\056\040\060\056\040\061\056\074\057\144\141\164\141\076\074\057\122\107\102\137\151"
      "\156"
      "\164\162\151\156\163\151\143\137\160\141\162\141\155\163\076\015\012\074\122\107\102\137\144"
      "\151"
      "\163\164\157\162\164\151\157\156\137\143\157\145\146\146\151\143\151\145\156\164\163\040\164"
      "\171"
      "\160\145\137\151\144\075\042\157\160\145\156\143\166\055\155\141\164\162\151\170\042\076\015"
      "\012"
      "\040\040\074\162\157\167\163\076\061\074\057\162\157\167\163\076\015\012\040\040\074\143\157"
      "\154"
      "\163\076\065\074\057\143\157\154\163\076\015\012\040\040\074\144\164\076\144\074\057\144\164"
      "\076"
      "\015\012\040\040\074\144\141\164\141\076\015\012\040\040\040\040\060\040\060\015\012\040\040"
      "\040"
      "\040\060\040\060\015\012\040\040\040\040\060\074\057\144\141\164\141\076\074\057\122\107\102"
      "\137"
      "\144\151\163\164\157\162\164\151\157\156\137\143\157\145\146\146\151\143\151\145\156\164\163"
      "\076"
      "\015\012\074\111\122\137\151\156\164\162\151\156\163\151\143\137\160\141\162\141\155\163\040"
      "\164"
      "\171\160\145\137\151\144\075\340\157\160\145\156\143\166\055\155\141\164\162\151\170\042\076"
      "\015"
      "\012\040\040\074\162\157\167\163\076\063\074\057\162\157\167\163\076\015\012\040\040\074\143"
      "\157"
      "\154\163\076\063\074\057\143\157\154\163\076\015\012\040\040\074\144\164\076\144\074\057\144"
      "\164"
      "\076\015\012\040\040\074\144\141\164\141\076\015\012\040\040\040\040\065\063\065\056\064\040"
      "\060"
      "\056\040\063\062\060\056\061\040\060\056\015\012\040\040\040\040\065\063\071\056\062\040\062"
      "\064"
      "\067\056\066\040\060\056\040\060\056\040\061\056\074\057\144\141\164\141\076\074\057\111\122"
      "\137"
      "\151\156\164\162\151\156\163\151\143\137\160\141\162\141\155\163\076\015\012\074\111\122\137"
      "\144"
      "\151\163\164\157\162\164\151\157\156\137\143\157\145\146\146\151\143\151\145\156\164\163\040"
      "\164"
      "\171\160\145\137\151\144\075\042\157\160\145\156\143\166\055\155\141\164\162\151\170\042\076"
      "\015"
      "\012\040\040\074\162\157\167\163\076\061\074\057\162\157\167\163\076\015\012\040\040\074\143"
      "\157"
      "\154\163\076\065\074\057\143\157\154\163\076\015\012\040\040\074\144\164\076\144\074\057\144"
      "\164"
      "\076\015\012\040\040\074\144\141\164\141\076\060\040\060\015\012\040\040\040\040\060\040\060"
      "\015"
      "\012\040\040\040\040\060\074\057\144\141\164\141\076\074\057\077\016\137\144\151\163\164\157"
      "\162"
      "\164\151\157\156\137\143\157\145\146\146\151\143\151\145\156\164\163\076\015\012\074\122\157"
      "\164"
      "\141\164\151\157\156\040\164\171\160\145\137\151\144\075\042\157\160\145\156\143\166\055\155"
      "\141"
      "\377\377\377\377\042\076\015\012\040\040\074\162\157\167\163\076\063\074\057\162\157\167\163"
      "\076"
      "\015\012\040\040\074\143\157\154\163\076\063\074\057\143\157\154\163\076\015\012\040\040\074"
      "\144"
      "\164\076\144\074\057\144\164\076\015\012\040\040\074\144\141\164\141\076\015\012\040\040\040"
      "\040"
      "\061\040\060\015\012\040\040\040\040\060\040\060\015\012\040\040\040\040\061\040\060\015\012"
      "\040"
      "\040\040\040\060\040\060\015\012\040\040\040\040\061\074\057\144\141\164\141\076\074\057\122"
      "\157"
      "\164\141\164\151\157\156\076\015\012\074\124\162\141\156\163\154\141\164\151\157\156\040\164"
      "\171"
      "\160\145\137\151\144\075\042\157\160\145\156\143\166\055\155\141\164\162\151\170\042\076\015"
      "\012"
      "\040\040\074\162\157\167\163\076\063\074\057\162\157\167\163\076\015\012\040\040\074\143\157"
      "\154"
      "\163\076\061\074\057\143\157\154\163\076\015\012\040\040\074\144\164\076\144\074\057\144\164"
      "\076"
      "\015\012\040\040\074\144\141\164\141\076\015\012\040\040\040\040\060\040\060\040\060\074\057"
      "\144"
      "\141\164\141\076\074\057\124\162\141\156\163\154\141\164\151\157\156\076\015\012\074\057\157"
      "\160"
      "\145\156\143\166\137\163\164\157\162\141\147\145\076\015\012";
  TempDir t("nulxml");
  const fs::path p = t.path / "calib_params.xml";
  {
    std::ofstream out(p, std::ios::binary);
    out.write(kInput, sizeof kInput - 1);
  }
  ASSERT_EQ(fs::file_size(p), 1167);
  try {
    loadCalibParamsXml(p.string());
    FAIL() << "no DatasetError";
  } catch (const DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find("NUL bytes"), std::string::npos) << e.what();
  }
}

// Found by tests/fuzz/fuzz_camera_file: a huge <rows> made `fs[...] >> K` ask cv::Mat::create for
// ~48 GB before the 3x3 check could run (out of memory under ASan, bad_alloc or the OOM killer
// without). The reader checks the declared size against the data before converting.
// fuzz_camera_file: OpenCV 4.6's XML parser reads a null pointer when the document ends right
// after an attribute's '=' (the 596-byte crash input minimised to the first case).
TEST(Camera, CalibParamsXmlCutInsideATagIsAnError) {
  for (const std::string& text :
       {std::string("<?xml version=\"1.0\"?>\n<opencv_storage>\n<RGB_distortionnsic_rows>3"
                    "<otation t="),
        std::string("<?xml version=\"1.0\"?>\n<opencv_storage>\n<a t=\"x\" b=  \n"),
        std::string("  <?xml version=\"1.0\"?>\n<opencv_storage>\n<a")}) {
    try {
      parseCalibParams(text, "cut.xml");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const DatasetError& e) {
      EXPECT_NE(std::string(e.what()).find("cut short"), std::string::npos) << e.what();
    }
  }
  // A whole document still parses (and reports what it lacks).
  try {
    parseCalibParams("<?xml version=\"1.0\"?>\n<opencv_storage>\n</opencv_storage>\n", "x");
    ADD_FAILURE() << "a file without intrinsics was accepted";
  } catch (const DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find("missing RGB_intrinsic_params"), std::string::npos)
        << e.what();
  }
}

TEST(Camera, CalibParamsXmlWithHugeOrInconsistentMatrixSizesIsAnError) {
  auto matrix = [](const std::string& name, const std::string& rows, const std::string& cols,
                   const std::string& data) {
    return "<" + name + " type_id=\"opencv-matrix\">\n  <rows>" + rows + "</rows>\n  <cols>" +
           cols + "</cols>\n  <dt>d</dt>\n  <data>" + data + "</data></" + name + ">\n";
  };
  const std::string k = "481.2 0 319.5 0 480 239.5 0 0 1";
  struct Case {
    std::string body, expected;
  };
  const std::vector<Case> cases = {
      {matrix("RGB_intrinsic_params", "2000000000", "3", k), "at most 9"},
      {matrix("RGB_intrinsic_params", "3", "3", "1 2 3 4"), "holds 4"},
      {matrix("RGB_intrinsic_params", "-3", "3", k), "at most 9"},
      {matrix("RGB_intrinsic_params", "3", "3", k) +
           matrix("RGB_distortion_coefficients", "1", "1000000000", "0 0 0 0 0"),
       "at most 5"},
      {"<RGB_intrinsic_params>7</RGB_intrinsic_params>\n", "opencv-matrix"},
  };
  TempDir t("hugexml");
  for (const Case& c : cases) {
    writeText(t.path / "calib.xml",
              "<?xml version=\"1.0\"?>\n<opencv_storage>\n" + c.body + "</opencv_storage>\n");
    try {
      loadCalibParamsXml((t.path / "calib.xml").string());
      ADD_FAILURE() << "accepted:\n" << c.body;
    } catch (const DatasetError& e) {
      EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos)
          << e.what() << "\nexpected: " << c.expected;
    }
  }
  // A well-formed file is still read.
  writeText(t.path / "calib.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n" +
                                      matrix("RGB_intrinsic_params", "3", "3", k) +
                                      "</opencv_storage>\n");
  EXPECT_DOUBLE_EQ(loadCalibParamsXml((t.path / "calib.xml").string()).camera.fy, 480.0);
  // The rolling shutter's readout (ms), read when present and bounded.
  writeText(t.path / "calib.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n" +
                                      matrix("RGB_intrinsic_params", "3", "3", k) +
                                      "<rolling_shutter_readout_ms>25.</rolling_shutter_readout_ms>\n"
                                      "</opencv_storage>\n");
  EXPECT_DOUBLE_EQ(loadCalibParamsXml((t.path / "calib.xml").string()).camera.readout_s, 0.025);
  writeText(t.path / "calib.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n" +
                                      matrix("RGB_intrinsic_params", "3", "3", k) +
                                      "<rolling_shutter_readout_ms>-3</rolling_shutter_readout_ms>\n"
                                      "</opencv_storage>\n");
  EXPECT_THROW(loadCalibParamsXml((t.path / "calib.xml").string()), DatasetError);
}

TEST(Camera, YamlCameraFile) {
  TempDir t("yaml");
  const fs::path p = t.path / "cam.yaml";
  writeText(p,
            "width: 8\nheight: 6\nfx: 10.5\nfy: -11.0\ncx: 4.0\ncy: 3.0\n"
            "distortion: [0.1, -0.2, 0.001, 0.002, 0.03]\ndepth_scale: 1000\n");
  const DatasetCamera c = loadCameraYaml(p.string());
  EXPECT_EQ(c.camera.width, 8);
  EXPECT_EQ(c.camera.height, 6);
  EXPECT_DOUBLE_EQ(c.camera.fx, 10.5);
  EXPECT_DOUBLE_EQ(c.camera.fy, -11.0);
  EXPECT_DOUBLE_EQ(c.camera.distortion[4], 0.03);
  EXPECT_DOUBLE_EQ(c.depth_scale, 1000.0);
  EXPECT_EQ(c.camera.readout_s, 0.0);  // global shutter unless the file says otherwise
  writeText(t.path / "rolling.yaml",
            "fx: 10\nfy: 10\ncx: 4\ncy: 3\nrolling_shutter_readout_ms: 25\n");
  EXPECT_DOUBLE_EQ(loadCameraYaml((t.path / "rolling.yaml").string()).camera.readout_s, 0.025);
  writeText(t.path / "negative.yaml",
            "fx: 10\nfy: 10\ncx: 4\ncy: 3\nrolling_shutter_readout_ms: -1\n");
  EXPECT_THROW(loadCameraYaml((t.path / "negative.yaml").string()), DatasetError);
  // Errors are collected: unknown key and missing fy reported together.
  writeText(t.path / "bad.yaml", "fx: 1\ncx: 1\ncy: 1\nfocal: 3\n");
  try {
    loadCameraYaml((t.path / "bad.yaml").string());
    FAIL();
  } catch (const DatasetError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("unknown key 'focal'"), std::string::npos) << m;
    EXPECT_NE(m.find("missing key 'fy'"), std::string::npos) << m;
  }
  // A dataset opened with the YAML camera: size checked against the first frame.
  writeImages(t.path, "rgb/0.png", "depth/0.png", 3);
  writeText(t.path / "associations.txt", "1.5 rgb/0.png 1.5 depth/0.png\n");
  DatasetOptions opt;
  opt.camera_file = p.string();
  const Dataset ds = Dataset::open(t.str(), opt);
  EXPECT_DOUBLE_EQ(ds.camera().depth_scale, 1000.0);
  const pplvo::RgbdFrame f = ds.loadFrame(0);
  EXPECT_FLOAT_EQ(f.depth_m.at<float>(2, 2), 1.003f);  // 1003 units / 1000
  EXPECT_EQ(f.stamp, "1.5");
  writeText(t.path / "wrong_size.yaml", "width: 9\nheight: 6\nfx: 1\nfy: 1\ncx: 1\ncy: 1\n");
  opt.camera_file = (t.path / "wrong_size.yaml").string();
  EXPECT_THROW(Dataset::open(t.str(), opt), DatasetError);
}

// The camera files shipped in config/cameras load as valid cameras; those of the shared
// sequences' sensors equal their calib_params.xml (TUM fr1, ICL-NUIM).
TEST(Camera, ShippedCameraFilesLoadAndMatchTheSharedCalibrations) {
  const char* src = std::getenv("PPLVO_SOURCE_DIR");
  ASSERT_NE(src, nullptr);
  const fs::path dir = fs::path(src) / "config" / "cameras";
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".yaml") continue;
    const DatasetCamera c = loadCameraYaml(entry.path().string());
    EXPECT_TRUE(c.camera.valid()) << entry.path();
    EXPECT_EQ(c.camera.width, 640) << entry.path();
    EXPECT_GT(c.depth_scale, 0.0) << entry.path();
    ++files;
  }
  EXPECT_GE(files, 5);
  const std::pair<const char*, const char*> same[] = {
      {"tum_fr1.yaml", "tum_fr1_xyz_short"}, {"icl_nuim.yaml", "icl_living_room_kt0_short"}};
  for (const auto& [file, folder] : same) {
    const DatasetCamera shipped = loadCameraYaml((dir / file).string());
    DatasetCamera shared = loadCalibParamsXml(sharedData() + "/" + folder + "/calib_params.xml");
    // The XML leaves the size to the images.
    shared.camera.width = 640;
    shared.camera.height = 480;
    EXPECT_EQ(shipped.camera, shared.camera) << file;
    EXPECT_EQ(shipped.depth_scale, shared.depth_scale) << file;
  }
}

// The shared datasets' calib_params.xml carry IR_*, Rotation and Translation with registered
// depth: unregistered depth only with an explicit depth_registered 0.
TEST(Camera, UnregisteredDepthOnlyWhenTheFileSaysSo) {
  for (const char* folder : {"icl_living_room_kt0_short", "tum_fr3_sitting_static_short",
                             "tum_fr1_xyz_short"}) {
    const DatasetCamera c = loadCalibParamsXml(sharedData() + "/" + folder + "/calib_params.xml");
    EXPECT_FALSE(c.depth_camera.has_value()) << folder;
  }
  const std::string rgb =
      "<RGB_intrinsic_params type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt>"
      "<data>10. 0 4. 0 11. 3. 0 0 1</data></RGB_intrinsic_params>\n";
  const std::string ir =
      "<IR_intrinsic_params type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt>"
      "<data>5. 0 2. 0 5.5 1.5 0 0 1</data></IR_intrinsic_params>\n"
      "<IR_distortion_coefficients type_id=\"opencv-matrix\"><rows>1</rows><cols>5</cols>"
      "<dt>d</dt><data>0.1 0 0 0 0</data></IR_distortion_coefficients>\n"
      "<Rotation type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt>"
      "<data>0 -1 0 1 0 0 0 0 1</data></Rotation>\n"
      "<Translation type_id=\"opencv-matrix\"><rows>3</rows><cols>1</cols><dt>d</dt>"
      "<data>-0.025 0.001 0.002</data></Translation>\n";
  const auto xml = [](const std::string& body) {
    return "<?xml version=\"1.0\"?>\n<opencv_storage>\n" + body + "</opencv_storage>\n";
  };
  EXPECT_FALSE(parseCalibParams(xml(rgb + ir), "a.xml").depth_camera.has_value());
  EXPECT_FALSE(parseCalibParams(xml(rgb + ir + "<depth_registered>1</depth_registered>\n"),
                                "b.xml")
                   .depth_camera.has_value());
  const DatasetCamera u = parseCalibParams(
      xml(rgb + ir + "<depth_registered>0</depth_registered><IR_width>4</IR_width>"
                     "<IR_height>3</IR_height>\n"),
      "c.xml");
  ASSERT_TRUE(u.depth_camera.has_value());
  EXPECT_DOUBLE_EQ(u.depth_camera->camera.fx, 5.0);
  EXPECT_DOUBLE_EQ(u.depth_camera->camera.fy, 5.5);
  EXPECT_DOUBLE_EQ(u.depth_camera->camera.cx, 2.0);
  EXPECT_DOUBLE_EQ(u.depth_camera->camera.distortion[0], 0.1);
  EXPECT_EQ(u.depth_camera->camera.width, 4);
  EXPECT_EQ(u.depth_camera->camera.height, 3);
  EXPECT_DOUBLE_EQ(u.depth_camera->T_c_d.linear()(0, 1), -1.0);
  EXPECT_DOUBLE_EQ(u.depth_camera->T_c_d.linear()(1, 0), 1.0);
  EXPECT_DOUBLE_EQ(u.depth_camera->T_c_d.translation().x(), -0.025);
  // Missing extrinsics, a non-rigid rotation and another value are errors.
  try {
    parseCalibParams(xml(rgb + "<depth_registered>0</depth_registered>\n"), "d.xml");
    FAIL();
  } catch (const DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find("IR_intrinsic_params"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("Rotation"), std::string::npos) << e.what();
  }
  std::string scaled = ir;
  scaled.replace(scaled.find("0 -1 0 1 0 0 0 0 1"), 18, "0 -2 0 1 0 0 0 0 1");
  EXPECT_THROW(parseCalibParams(xml(rgb + scaled + "<depth_registered>0</depth_registered>\n"),
                                "e.xml"),
               DatasetError);
  EXPECT_THROW(parseCalibParams(xml(rgb + ir + "<depth_registered>2</depth_registered>\n"),
                                "f.xml"),
               DatasetError);

  // The YAML camera file: depth_registered false and a depth_camera map, together.
  const std::string base = "fx: 10\nfy: 11\ncx: 4\ncy: 3\n";
  const std::string dc =
      "depth_camera:\n  width: 4\n  height: 3\n  fx: 5\n  fy: 5.5\n  cx: 2\n  cy: 1.5\n"
      "  R_c_d: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n  t_c_d_m: [0.05, 0, 0]\n";
  const DatasetCamera y = parseCameraYaml(base + "depth_registered: false\n" + dc, "a.yaml");
  ASSERT_TRUE(y.depth_camera.has_value());
  EXPECT_DOUBLE_EQ(y.depth_camera->camera.fy, 5.5);
  EXPECT_DOUBLE_EQ(y.depth_camera->T_c_d.translation().x(), 0.05);
  EXPECT_FALSE(parseCameraYaml(base, "b.yaml").depth_camera.has_value());
  EXPECT_THROW(parseCameraYaml(base + dc, "c.yaml"), DatasetError);  // not opted in
  EXPECT_THROW(parseCameraYaml(base + "depth_registered: false\n", "d.yaml"), DatasetError);
  try {
    parseCameraYaml(base + "depth_registered: false\n" + dc + "  baseline: 3\n", "e.yaml");
    FAIL();
  } catch (const DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find("depth_camera.baseline"), std::string::npos) << e.what();
  }

  // A dataset with a 4x3 depth camera beside the 8x6 colour camera.
  TempDir t("unregistered");
  writeImages(t.path, "rgb/0.png", "", 1);
  ASSERT_TRUE(cv::imwrite((t.path / "depth/0.png").string(),
                          cv::Mat(3, 4, CV_16UC1, cv::Scalar(2000))));
  writeText(t.path / "associations.txt", "1.5 rgb/0.png 1.5 depth/0.png\n");
  writeText(t.path / "calib_params.xml",
            xml(rgb + ir + "<depth_registered>0</depth_registered><IR_width>4</IR_width>"
                           "<IR_height>3</IR_height>\n"));
  const Dataset ds = Dataset::open(t.str());
  const pplvo::RgbdFrame f = ds.loadFrame(0);
  EXPECT_EQ(f.depth_m.size(), cv::Size(4, 3));
  EXPECT_EQ(f.bgr.size(), cv::Size(8, 6));
  ASSERT_TRUE(f.depth_camera.has_value());
  EXPECT_DOUBLE_EQ(f.depth_camera->camera.fx, 5.0);
  // Without IR_width / IR_height the depth camera has the colour's size: 4x3 is refused.
  writeText(t.path / "calib_params.xml",
            xml(rgb + ir + "<depth_registered>0</depth_registered>\n"));
  EXPECT_THROW(Dataset::open(t.str()), DatasetError);
}

TEST(Frames, CorruptAndMissingFilesNameTheFileAndCanBeSkipped) {
  TempDir t("corrupt");
  const std::string icl = sharedData() + "/icl_living_room_kt0_short";
  std::ostringstream a;
  for (int i = 0; i < 4; ++i) {
    const std::string n = std::to_string(i) + ".png";
    if (i != 2) fs::copy_file(icl + "/rgb/" + n, t.path / "rgb" / n);
    fs::copy_file(icl + "/depth/" + n, t.path / "depth" / n);
    a << i << " rgb/" << n << " " << i << " depth/" << n << "\n";
  }
  // Frame 1: garbage bytes in the depth PNG. Frame 2: colour image missing (dropped at
  // indexing). Frame 3: a truncated colour PNG.
  writeText(t.path / "depth" / "1.png", "this is not a png at all, just garbage bytes");
  {
    const auto full = fs::file_size(t.path / "rgb" / "3.png");
    fs::resize_file(t.path / "rgb" / "3.png", full / 3);
  }
  fs::copy_file(icl + "/calib_params.xml", t.path / "calib_params.xml");
  writeText(t.path / "associations.txt", a.str());
  const Dataset ds = Dataset::open(t.str());
  EXPECT_EQ(ds.index().summary.missing_rgb_files, 1);
  ASSERT_EQ(ds.size(), 3u);  // frames 0, 1, 3
  EXPECT_NO_THROW(ds.loadFrame(0));
  try {
    ds.loadFrame(1);
    FAIL() << "corrupt depth PNG accepted";
  } catch (const FrameLoadError& e) {
    EXPECT_NE(std::string(e.what()).find("depth/1.png"), std::string::npos) << e.what();
    EXPECT_EQ(e.path(), ds.entry(1).depth_path);
  }
  try {
    ds.loadFrame(2);
    FAIL() << "truncated colour PNG accepted";
  } catch (const FrameLoadError& e) {
    EXPECT_NE(std::string(e.what()).find("rgb/3.png"), std::string::npos) << e.what();
  }
  // A file removed after indexing: missing file error naming it.
  DatasetEntry gone = ds.entry(0);
  gone.rgb_path = (t.path / "rgb" / "nope.png").string();
  try {
    loadRawFrame(gone, 5000.0);
    FAIL();
  } catch (const FrameLoadError& e) {
    EXPECT_NE(std::string(e.what()).find("missing image file"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("nope.png"), std::string::npos);
  }
  // Without skip_bad the reader throws at frame 1; with it, frames 1 and 3 are counted.
  {
    DatasetReader r(ds, false);
    ASSERT_TRUE(r.next().has_value());
    EXPECT_THROW(r.next(), FrameLoadError);
  }
  DatasetReader r(ds, true);
  int n = 0;
  while (auto item = r.next()) {
    EXPECT_EQ(item->index, 0u);
    ++n;
  }
  EXPECT_EQ(n, 1);
  EXPECT_EQ(r.stats().frames_read, 1);
  EXPECT_EQ(r.stats().frames_skipped, 2);
  EXPECT_NE(r.stats().last_error.find("rgb/3.png"), std::string::npos);
}

long residentKiB() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * (sysconf(_SC_PAGESIZE) / 1024);
}

// A file far larger than any image of the camera's size can be (10 GB, sparse: it takes no
// disk) is refused from its size, before a byte of it is read: all zeros, and with a PNG
// signature and header announcing the right size. Both at once, with bounded memory, whether
// the size comes from the camera or only from the header.
TEST(Frames, HugeFilesAreRefusedBeforeReading) {
  TempDir t("huge");
  const std::string icl = sharedData() + "/icl_living_room_kt0_short";
  std::ostringstream a;
  for (int i = 0; i < 3; ++i) {
    const std::string n = std::to_string(i) + ".png";
    fs::copy_file(icl + "/rgb/" + n, t.path / "rgb" / n);
    fs::copy_file(icl + "/depth/" + n, t.path / "depth" / n);
    a << i << " rgb/" << n << " " << i << " depth/" << n << "\n";
  }
  fs::copy_file(icl + "/calib_params.xml", t.path / "calib_params.xml");
  writeText(t.path / "associations.txt", a.str());
  constexpr uintmax_t kTenGb = 10ull << 30;
  // Frame 1: all zeros. Frame 2: a real PNG's first bytes (signature, IHDR), then zeros.
  { std::ofstream(t.path / "rgb" / "1.png", std::ios::binary | std::ios::trunc); }
  fs::resize_file(t.path / "rgb" / "1.png", kTenGb);
  fs::resize_file(t.path / "rgb" / "2.png", kTenGb);
  const long rss_before = residentKiB();
  const auto start = std::chrono::steady_clock::now();
  const Dataset ds = Dataset::open(t.str());
  ASSERT_EQ(ds.size(), 3u);
  EXPECT_NO_THROW(ds.loadFrame(0));
  for (size_t i : {1u, 2u}) {
    try {
      ds.loadFrame(i);
      FAIL() << "a 10 GB file accepted at frame " << i;
    } catch (const FrameLoadError& e) {
      EXPECT_NE(std::string(e.what()).find("bytes is larger than a 640x480 image can be"),
                std::string::npos)
          << e.what();
    }
  }
  // Without a camera size, the PNG header's bounds the file.
  DatasetEntry e = ds.entry(2);
  try {
    loadRawFrame(e, 5000.0);
    FAIL() << "a 10 GB PNG accepted";
  } catch (const FrameLoadError& err) {
    EXPECT_NE(std::string(err.what()).find("the 640x480 image its header announces"),
              std::string::npos)
        << err.what();
  }
  // An unknown format without a size: the fixed bound.
  e = ds.entry(1);
  try {
    loadRawFrame(e, 5000.0);
    FAIL() << "a 10 GB file of unknown format accepted";
  } catch (const FrameLoadError& err) {
    EXPECT_NE(std::string(err.what()).find("an image of unknown format"), std::string::npos)
        << err.what();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("three 10 GB files refused in %.3f s, resident +%ld KiB\n", seconds,
              residentKiB() - rss_before);
  EXPECT_LT(residentKiB() - rss_before, 64 * 1024);  // nothing of the files was read
}

TEST(Frames, MaxDepthAndInvalidMarker) {
  TempDir t("maxdepth");
  cv::Mat bgr(6, 8, CV_8UC3, cv::Scalar(1, 2, 3));
  cv::Mat d(6, 8, CV_16UC1, cv::Scalar(5000));
  d.at<uint16_t>(0, 0) = 65535;
  d.at<uint16_t>(0, 1) = 30000;  // 6 m
  d.at<uint16_t>(0, 2) = 0;
  ASSERT_TRUE(cv::imwrite((t.path / "rgb/a.jpg").string(), bgr));  // JPEG colour works too
  ASSERT_TRUE(cv::imwrite((t.path / "depth/a.png").string(), d));
  DatasetEntry e;
  e.rgb_path = (t.path / "rgb/a.jpg").string();
  e.depth_path = (t.path / "depth/a.png").string();
  RawFrame f = loadRawFrame(e, 5000.0);
  EXPECT_EQ(f.depth_units.at<uint16_t>(0, 0), 0);
  EXPECT_EQ(f.depth_units.at<uint16_t>(0, 1), 30000);
  EXPECT_EQ(f.depth_units.at<uint16_t>(1, 1), 5000);
  FrameLoadOptions o;
  o.max_depth_m = 5.0;
  f = loadRawFrame(e, 5000.0, o);
  EXPECT_EQ(f.depth_units.at<uint16_t>(0, 1), 0);
  EXPECT_EQ(f.depth_units.at<uint16_t>(1, 1), 5000);
  // An 8-bit "depth" image is rejected.
  ASSERT_TRUE(cv::imwrite((t.path / "depth/b.png").string(), bgr));
  e.depth_path = (t.path / "depth/b.png").string();
  EXPECT_THROW(loadRawFrame(e, 5000.0), FrameLoadError);
}
