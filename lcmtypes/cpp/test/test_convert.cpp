#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "pplvo/msgs/convert.h"

namespace pplvo::msgs {
namespace {
using Img = pplvo_msgs::image_t;

PinholeCamera vga() {
  PinholeCamera c;
  c.width = 64;
  c.height = 48;
  c.fx = 52.5;
  c.fy = -52.0;
  c.cx = 31.5;
  c.cy = 23.5;
  c.distortion = {0.1, -0.01, 0.001, 0.002, 0.0};
  return c;
}

RgbdFrame makeFrame() {
  RgbdFrame f;
  f.utime = 1341845688561749;
  f.depth_utime = 1341845688548315;
  f.seq = 7;
  f.stamp = "1341845688.561749";
  f.camera = vga();
  f.bgr = cv::Mat(48, 64, CV_8UC3);
  cv::randu(f.bgr, 0, 255);
  f.depth_m = cv::Mat(48, 64, CV_32FC1);
  cv::randu(f.depth_m, 0.5f, 4.0f);
  f.depth_m.at<float>(3, 4) = 0.0f;
  return f;
}

template <typename Msg>
Msg roundTripBytes(const Msg& msg) {
  std::vector<uint8_t> buf(msg.getEncodedSize());
  EXPECT_EQ(msg.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  Msg out;
  EXPECT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  return out;
}

TEST(Convert, CameraRoundTrip) {
  PinholeCamera c = vga();
  EXPECT_EQ(fromMsg(roundTripBytes(toMsg(c))), c);
  c.readout_s = 0.025;  // a rolling shutter travels with the camera
  EXPECT_EQ(fromMsg(roundTripBytes(toMsg(c))).readout_s, 0.025);
}

TEST(Convert, InvalidCameraThrows) {
  auto m = toMsg(vga());
  m.fx = 0;
  EXPECT_THROW(fromMsg(m), MessageError);
  for (const double readout : {-0.01, 1.5, std::nan("")}) {
    auto r = toMsg(vga());
    r.readout_s = readout;
    EXPECT_THROW(fromMsg(r), MessageError) << readout;
  }
}

class EncodingRoundTrip : public ::testing::TestWithParam<int8_t> {};

TEST_P(EncodingRoundTrip, LosslessEncodingsReproduceDepth) {
  const RgbdFrame f = makeFrame();
  const auto msg = roundTripBytes(toMsg(f, 5000.0, Img::ENCODING_PNG, GetParam(), "test"));
  const RgbdFrame back = fromMsg(msg);
  EXPECT_EQ(back.utime, f.utime);
  EXPECT_EQ(back.depth_utime, f.depth_utime);
  EXPECT_EQ(back.seq, f.seq);
  EXPECT_EQ(back.stamp, f.stamp);
  EXPECT_EQ(back.camera, f.camera);
  EXPECT_EQ(cv::norm(back.bgr, f.bgr, cv::NORM_INF), 0.0);
  // Depth is quantised to 1/5000 m.
  EXPECT_LE(cv::norm(back.depth_m, f.depth_m, cv::NORM_INF), 0.5 / 5000.0 + 1e-6);
  EXPECT_EQ(back.depth_m.at<float>(3, 4), 0.0f);
}

INSTANTIATE_TEST_SUITE_P(DepthEncodings, EncodingRoundTrip,
                         ::testing::Values(Img::ENCODING_RAW_U16, Img::ENCODING_ZLIB_U16,
                                           Img::ENCODING_PNG_U16));

TEST(Convert, JpegIsCloseAndRawIsExact) {
  const RgbdFrame f = makeFrame();
  cv::Mat smooth;
  cv::GaussianBlur(f.bgr, smooth, cv::Size(9, 9), 3);
  const auto jpg = decodeImage(encodeImage(smooth, Img::ENCODING_JPEG, 95));
  EXPECT_LT(cv::norm(jpg, smooth, cv::NORM_L1) / smooth.total() / 3, 4.0);
  const auto raw = decodeImage(encodeImage(f.bgr, Img::ENCODING_RAW_BGR8));
  EXPECT_EQ(cv::norm(raw, f.bgr, cv::NORM_INF), 0.0);
}

TEST(Convert, ZlibU8IsLosslessAndSmallForLabels) {
  cv::Mat labels(48, 64, CV_8UC1, cv::Scalar(0));
  labels(cv::Rect(5, 7, 30, 20)).setTo(3);
  labels.at<uint8_t>(40, 60) = 255;
  const auto m = encodeImage(labels, Img::ENCODING_ZLIB_U8);
  EXPECT_EQ(m.encoding, Img::ENCODING_ZLIB_U8);
  EXPECT_LT(m.data.size(), labels.total() / 4);  // label images are mostly runs
  const cv::Mat back = decodeImage(roundTripBytes(m));
  ASSERT_EQ(back.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(back, labels, cv::NORM_INF), 0.0);
  EXPECT_THROW(encodeImage(cv::Mat(4, 4, CV_16UC1), Img::ENCODING_ZLIB_U8), MessageError);
}

TEST(Convert, SizeFieldDisagreeingWithDataThrows) {
  auto m = encodeImage(cv::Mat(4, 4, CV_16UC1, cv::Scalar(1000)), Img::ENCODING_RAW_U16);
  m.size = 10;
  EXPECT_THROW(decodeImage(m), MessageError);
  m.size = static_cast<int32_t>(m.data.size());
  m.width = 5;  // dimensions disagree with the payload
  EXPECT_THROW(decodeImage(m), MessageError);
}

TEST(Convert, CorruptCompressedPayloadsThrow) {
  const cv::Mat depth(16, 16, CV_16UC1, cv::Scalar(2000));
  for (int8_t enc : {Img::ENCODING_ZLIB_U16, Img::ENCODING_PNG_U16}) {
    auto m = encodeImage(depth, enc);
    m.data.resize(m.data.size() / 2);
    m.size = static_cast<int32_t>(m.data.size());
    EXPECT_THROW(decodeImage(m), MessageError) << encodingName(enc);
  }
}

// Only a PNG or JPEG file reaches cv::imdecode for those encodings: other formats OpenCV would
// also read (a Radiance HDR file goes through a temporary file in /tmp) are corrupt payloads.
TEST(Convert, PayloadsWithoutTheirEncodingsSignatureThrow) {
  const cv::Mat grey(16, 16, CV_8UC1, cv::Scalar(90));
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  auto png = encodeImage(grey, Img::ENCODING_PNG);
  auto jpeg = encodeImage(bgr, Img::ENCODING_JPEG);
  EXPECT_NO_THROW(decodeImage(png));
  EXPECT_NO_THROW(decodeImage(jpeg));
  // The same bytes under the other's encoding, then an HDR header under each.
  std::swap(png.encoding, jpeg.encoding);
  EXPECT_THROW(decodeImage(png), MessageError);
  EXPECT_THROW(decodeImage(jpeg), MessageError);
  const std::string hdr = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16 +X 16\n";
  for (auto* m : {&png, &jpeg}) {
    m->data.assign(hdr.begin(), hdr.end());
    m->size = static_cast<int32_t>(m->data.size());
    try {
      decodeImage(*m);
      ADD_FAILURE() << "accepted an HDR header as " << encodingName(m->encoding);
    } catch (const MessageError& e) {
      EXPECT_NE(std::string(e.what()).find("signature"), std::string::npos) << e.what();
    }
  }
}

// Every plane is allocated at the message's size before its payload is decoded, so the size
// is bounded first (issue 20): at most pplvo::kMaxImagePixels; a zlib payload long enough to
// inflate to the plane; a PNG or JPEG payload whose header announces the message's size.
// Before, a 16x16 message whose JPEG header announced 20000x20000 had cv::imdecode allocate
// 1.2 GB before it failed ("corrupt jpeg payload"), and a 10-byte zlib payload of a
// 16384x16384 f32 message had 1 GB allocated.
TEST(Convert, PlaneSizesAreBoundedBeforeDecoding) {
  auto expectError = [](const Img& m, const std::string& want) {
    try {
      decodeImage(m);
      ADD_FAILURE() << "decoded; wanted '" << want << "'";
    } catch (const MessageError& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  };
  auto raw = encodeImage(cv::Mat(4, 4, CV_8UC1, cv::Scalar(3)), Img::ENCODING_RAW_U8);
  raw.width = raw.height = 8192;
  expectError(raw, "image dimensions 8192x8192 are invalid (at most 16777216 pixels)");

  auto z = encodeImage(cv::Mat(16, 16, CV_32FC1, cv::Scalar(1.f)), Img::ENCODING_ZLIB_F32);
  z.width = z.height = 4000;
  expectError(z, "cannot inflate to the 64000000 bytes of a 4000x4000 zlib_f32 plane");

  cv::Mat bgr(16, 16, CV_8UC3, cv::Scalar(10, 20, 30));
  auto jpeg = encodeImage(bgr, Img::ENCODING_JPEG);
  for (size_t i = 2; i + 9 < jpeg.data.size(); ++i) {  // SOF0: FF C0 len(2) P height width
    if (jpeg.data[i] == 0xFF && jpeg.data[i + 1] == 0xC0) {
      jpeg.data[i + 5] = jpeg.data[i + 7] = 20000 >> 8;
      jpeg.data[i + 6] = jpeg.data[i + 8] = 20000 & 255;
      break;
    }
  }
  expectError(jpeg, "corrupt jpeg payload: announced size 20000x20000 differs from the expected 16x16");
  jpeg.data.resize(2);  // SOI only: no frame header
  jpeg.size = 2;
  expectError(jpeg, "signature");
  jpeg.data = {0xFF, 0xD8, 0xFF, 0xD9};  // SOI, EOI
  jpeg.size = 4;
  expectError(jpeg, "no JPEG frame header");

  auto png = encodeImage(bgr, Img::ENCODING_PNG);
  png.data[16] = png.data[20] = 0;  // IHDR width and height: 0x00004E20 = 20000
  png.data[17] = png.data[21] = 0;
  png.data[18] = png.data[22] = 20000 >> 8;
  png.data[19] = png.data[23] = 20000 & 255;
  expectError(png, "corrupt png payload: announced size 20000x20000 differs from the expected 16x16");
  // The message's own size still decodes, PNG and JPEG.
  EXPECT_EQ(decodeImage(encodeImage(bgr, Img::ENCODING_PNG)).size(), cv::Size(16, 16));
  EXPECT_EQ(decodeImage(encodeImage(bgr, Img::ENCODING_JPEG)).size(), cv::Size(16, 16));
}

TEST(Convert, FrameWithMismatchedDepthSizeThrows) {
  RgbdFrame f = makeFrame();
  auto m = toMsg(f, 5000.0, Img::ENCODING_RAW_BGR8, Img::ENCODING_RAW_U16);
  m.depth = encodeImage(cv::Mat(10, 10, CV_16UC1, cv::Scalar(0)), Img::ENCODING_RAW_U16);
  EXPECT_THROW(fromMsg(m), MessageError);
  m = toMsg(f, 5000.0, Img::ENCODING_RAW_BGR8, Img::ENCODING_RAW_U16);
  m.depth_scale = 0;
  EXPECT_THROW(fromMsg(m), MessageError);
}

TEST(Convert, FrameWithADepthCameraOfItsOwnRoundTrips) {
  RgbdFrame f = makeFrame();
  EXPECT_EQ(toMsg(f, 5000.0, Img::ENCODING_RAW_BGR8, Img::ENCODING_RAW_U16).depth_frame,
            pplvo_msgs::rgbd_frame_t::DEPTH_REGISTERED);
  DepthCamera d;
  d.camera = vga();
  d.camera.width = 32;
  d.camera.height = 24;
  d.camera.fx = 30;
  d.T_c_d.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  d.T_c_d.translation() = Eigen::Vector3d(0.025, -0.001, 0.003);
  f.depth_camera = d;
  f.depth_m = cv::Mat(24, 32, CV_32FC1, cv::Scalar(1.5f));
  const auto m = roundTripBytes(toMsg(f, 5000.0, Img::ENCODING_RAW_BGR8, Img::ENCODING_PNG_U16));
  EXPECT_EQ(m.depth_frame, pplvo_msgs::rgbd_frame_t::DEPTH_OWN_CAMERA);
  const RgbdFrame back = fromMsg(m);
  ASSERT_TRUE(back.depth_camera.has_value());
  EXPECT_EQ(back.depth_camera->camera, d.camera);
  EXPECT_TRUE(back.depth_camera->T_c_d.isApprox(d.T_c_d, 0.0));
  EXPECT_EQ(back.depth_m.size(), cv::Size(32, 24));
  EXPECT_EQ(back.camera, f.camera);
  // The depth image must have the depth camera's size; unknown frames and a non-rigid
  // rotation are refused.
  auto bad = m;
  bad.depth_camera.width = 64;
  EXPECT_THROW(fromMsg(bad), MessageError);
  bad = m;
  bad.depth_frame = 2;
  EXPECT_THROW(fromMsg(bad), MessageError);
  bad = m;
  bad.R_c_d[0] = 2.0;
  EXPECT_THROW(fromMsg(bad), MessageError);
}

TEST(Convert, DepthMapRoundTrip) {
  DepthWithVariance d;
  d.depth_m = cv::Mat(48, 64, CV_32FC1);
  cv::randu(d.depth_m, 0.5f, 4.0f);
  d.var_m2 = d.depth_m.mul(d.depth_m) * 1e-4;
  d.window_length = 7;
  for (bool compress : {false, true}) {
    const auto m = roundTripBytes(toMsg(d, vga(), 5, 3, "3", pplvo_msgs::depth_map_t::STAGE_OGM, compress));
    const auto back = fromMsg(m);
    EXPECT_EQ(back.window_length, 7);
    EXPECT_EQ(cv::norm(back.depth_m, d.depth_m, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(back.var_m2, d.var_m2, cv::NORM_INF), 0.0);
  }
}

TEST(Convert, FrameImagesDecodeOnlyTheChosenImage) {
  const RgbdFrame f = makeFrame();
  for (const int8_t depth_encoding : {Img::ENCODING_RAW_U16, Img::ENCODING_PNG_U16}) {
    const auto m = toMsg(f, 5000.0, Img::ENCODING_PNG, depth_encoding);
    const RgbdFrame both = fromMsg(m);
    const RgbdFrame colour = fromMsg(m, 65535, FrameImages::kColour);
    const RgbdFrame depth = fromMsg(m, 65535, FrameImages::kDepth);
    EXPECT_TRUE(colour.depth_m.empty());
    EXPECT_TRUE(depth.bgr.empty());
    EXPECT_EQ(cv::norm(colour.bgr, both.bgr, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(depth.depth_m, both.depth_m, cv::NORM_INF), 0.0);
    EXPECT_EQ(colour.camera, both.camera);
    EXPECT_EQ(depth.seq, both.seq);
  }
}

TEST(Convert, FrameImagesStillCheckTheOtherImagesHeader) {
  const RgbdFrame f = makeFrame();
  for (const FrameImages images : {FrameImages::kColour, FrameImages::kDepth}) {
    auto m = toMsg(f, 5000.0, Img::ENCODING_RAW_BGR8, Img::ENCODING_RAW_U16);
    m.depth = encodeImage(cv::Mat(10, 10, CV_16UC1, cv::Scalar(0)), Img::ENCODING_RAW_U16);
    EXPECT_THROW(fromMsg(m, 65535, images), MessageError);  // sizes disagree
    m = toMsg(f, 5000.0, Img::ENCODING_RAW_BGR8, Img::ENCODING_RAW_U16);
    m.rgb = encodeImage(cv::Mat(10, 10, CV_8UC3, cv::Scalar(0)), Img::ENCODING_RAW_BGR8);
    EXPECT_THROW(fromMsg(m, 65535, images), MessageError);
    m = toMsg(f, 5000.0, Img::ENCODING_RAW_BGR8, Img::ENCODING_RAW_U16);
    m.depth = encodeImage(cv::Mat(48, 64, CV_8UC1, cv::Scalar(0)), Img::ENCODING_RAW_U8);
    EXPECT_THROW(fromMsg(m, 65535, images), MessageError);  // not a 16-bit depth
    m = toMsg(f, 5000.0, Img::ENCODING_RAW_BGR8, Img::ENCODING_RAW_U16);
    m.depth = pplvo_msgs::image_t();
    m.depth.encoding = Img::ENCODING_NONE;
    EXPECT_THROW(fromMsg(m, 65535, images), MessageError);  // no depth
    m = toMsg(f, 5000.0, Img::ENCODING_RAW_BGR8, Img::ENCODING_RAW_U16);
    m.rgb = pplvo_msgs::image_t();
    m.rgb.encoding = Img::ENCODING_NONE;
    EXPECT_THROW(fromMsg(m, 65535, images), MessageError);  // no colour
  }
}

TEST(Convert, DepthMapViewSharesRawPayloadsAndDecodesCompressedOnes) {
  DepthWithVariance d;
  d.depth_m = cv::Mat(48, 64, CV_32FC1);
  cv::randu(d.depth_m, 0.5f, 4.0f);
  d.var_m2 = d.depth_m.mul(d.depth_m) * 1e-4;
  d.window_length = 4;
  for (bool compress : {false, true}) {
    const auto m = roundTripBytes(toMsg(d, vga(), 5, 3, "3", pplvo_msgs::depth_map_t::STAGE_OGM, compress));
    const DepthWithVariance view = viewOfMsg(m);
    EXPECT_EQ(view.window_length, 4);
    EXPECT_EQ(cv::norm(view.depth_m, d.depth_m, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(view.var_m2, d.var_m2, cv::NORM_INF), 0.0);
    EXPECT_EQ(view.depth_m.data == m.depth.data.data(), !compress);
    EXPECT_EQ(view.var_m2.data == m.variance.data.data(), !compress);
  }
  auto bad = toMsg(d, vga(), 5, 3, "3", pplvo_msgs::depth_map_t::STAGE_OGM, false);
  bad.depth.data.pop_back();
  bad.depth.size = static_cast<int32_t>(bad.depth.data.size());
  EXPECT_THROW(viewOfMsg(bad), MessageError);
}

TEST(Convert, DepthMapCarriesItsTimeAlignmentAndRejectsAForgedOne) {
  DepthWithVariance d;
  d.depth_m = cv::Mat(48, 64, CV_32FC1, cv::Scalar(2.0f));
  d.var_m2 = cv::Mat(48, 64, CV_32FC1, cv::Scalar(1e-4f));
  d.time_alignment = DepthTimeAlignment{-0.42, 7};
  const auto m = roundTripBytes(toMsg(d, vga(), 5, 9, "9", pplvo_msgs::depth_map_t::STAGE_CGM));
  const DepthWithVariance back = fromMsg(m);
  EXPECT_EQ(back.time_alignment.scale, -0.42);
  EXPECT_EQ(back.time_alignment.motion_seq, 7);
  EXPECT_FALSE(fromMsg(toMsg(DepthWithVariance{d.depth_m, d.var_m2}, vga(), 5, 9, "9", 1))
                   .time_alignment.moved());
  auto forged = m;
  forged.time_alignment_scale = std::nan("");
  EXPECT_THROW(fromMsg(forged), MessageError);
  forged = m;
  forged.time_alignment_motion_seq = 9;  // the frame's own motion is not known yet
  EXPECT_THROW(fromMsg(forged), MessageError);
  forged.time_alignment_motion_seq = -3;  // any negative seq: not moved
  EXPECT_FALSE(fromMsg(forged).time_alignment.moved());
}

TEST(Convert, RawDepthMapWireBytesAreLcmGensEncoding) {
  // encodeRawDepthMap writes the planes straight into the packet; the bytes must be those of
  // the message toMsg() builds, encoded by lcm-gen, for any stamp, size, ROI and field values.
  struct Case {
    int rows, cols;
    std::string stamp;
    int8_t stage, reference;
    int window;
    bool roi;
    DepthTimeAlignment alignment;
  };
  const std::vector<Case> cases = {
      {48, 64, "1305031102.175304", pplvo_msgs::depth_map_t::STAGE_OGM, 2, 10, false,
       DepthTimeAlignment{-0.45, 1}},
      {1, 1, "", pplvo_msgs::depth_map_t::STAGE_CGM, 0, 1, false, DepthTimeAlignment{}},
      {7, 13, std::string(300, 's'), pplvo_msgs::depth_map_t::STAGE_SENSOR, -1, 3, true,
       DepthTimeAlignment{0.5, -7}}};
  std::vector<uint8_t> wire = {1, 2, 3};  // reused: any previous content is replaced
  for (const Case& c : cases) {
    DepthWithVariance d;
    cv::Mat depth(c.rows + 4, c.cols + 6, CV_32FC1);
    cv::randu(depth, 0.5f, 4.0f);
    d.depth_m = c.roi ? depth(cv::Rect(3, 2, c.cols, c.rows))
                      : depth(cv::Rect(0, 0, c.cols, c.rows)).clone();
    d.var_m2 = d.depth_m.mul(d.depth_m) * 1e-4;
    d.window_length = c.window;
    d.time_alignment = c.alignment;
    if (c.roi) {
      ASSERT_FALSE(d.depth_m.isContinuous());  // rows are copied one by one
    }
    PinholeCamera cam = vga();
    cam.width = c.cols;
    cam.height = c.rows;
    auto m = toMsg(d, cam, 5, 3, c.stamp, c.stage, false);
    m.reference = c.reference;
    std::vector<uint8_t> expected(static_cast<size_t>(m.getEncodedSize()));
    ASSERT_EQ(m.encode(expected.data(), 0, static_cast<int>(expected.size())),
              static_cast<int>(expected.size()));
    encodeRawDepthMap(d, cam, 5, 3, c.stamp, c.stage, c.reference, &wire);
    EXPECT_EQ(wire, expected) << c.rows << "x" << c.cols << " stamp of " << c.stamp.size();
  }
  DepthWithVariance wrong;  // no planes (as toMsg), a double plane, planes of two sizes
  EXPECT_THROW(encodeRawDepthMap(wrong, vga(), 0, 0, "", 0, 0, &wire), MessageError);
  wrong.depth_m = cv::Mat(4, 4, CV_32FC1, cv::Scalar(1));
  wrong.var_m2 = cv::Mat(4, 4, CV_64FC1, cv::Scalar(1));
  EXPECT_THROW(encodeRawDepthMap(wrong, vga(), 0, 0, "", 0, 0, &wire), MessageError);
  wrong.var_m2 = cv::Mat(4, 5, CV_32FC1, cv::Scalar(1));
  EXPECT_THROW(encodeRawDepthMap(wrong, vga(), 0, 0, "", 0, 0, &wire), MessageError);
}

TEST(Convert, StatusCarriesStages) {
  NodeCounters c;
  c.frames_in = 3;
  c.frames_skipped = 1;
  StageTimings t;
  t.add("cgm", 1.5);
  t.add("cgm", 2.5);
  const auto m = roundTripBytes(toStatusMsg("depth_filter", c, t, 42));
  ASSERT_EQ(m.n_stages, 1);
  EXPECT_EQ(m.stages[0].count, 2);
  EXPECT_DOUBLE_EQ(m.stages[0].mean_ms, 2.0);
  EXPECT_EQ(m.frames_skipped, 1);
}

}  // namespace
}  // namespace pplvo::msgs
