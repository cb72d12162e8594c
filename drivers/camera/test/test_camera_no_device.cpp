// With no sensor attached, pplvo-camera must fail fast with a clear message and a non-zero
// exit code, for both backends (this machine has no camera; set PPLVO_CAMERA_HARDWARE=1 on one
// that does to skip).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace {

struct RunResult {
  int exit_code = -1;
  double seconds = 0;
  std::string stderr_text;
};

RunResult runCamera(const std::string& args) {
  const std::string err = "/tmp/pplvo_camera_nodev_" + std::to_string(::getpid()) + ".txt";
  const std::string log = "/tmp/pplvo_camera_nodev_" + std::to_string(::getpid()) + ".lcmlog";
  // FAKENECT_PATH unset and the real libfreenect: no fake Kinect.
  const std::string cmd = "env -u FAKENECT_PATH timeout 30 " + std::string(PPLVO_CAMERA_EXE) + " " +
                          args + " --lcm-url 'file://" + log + "?mode=w' 2> " + err;
  const auto t0 = std::chrono::steady_clock::now();
  const int rc = std::system(cmd.c_str());
  RunResult r;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.exit_code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  std::ifstream f(err);
  std::stringstream ss;
  ss << f.rdbuf();
  r.stderr_text = ss.str();
  std::remove(err.c_str());
  std::remove(log.c_str());
  return r;
}

class NoDevice : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override {
    if (std::getenv("PPLVO_CAMERA_HARDWARE")) GTEST_SKIP() << "a camera is attached";
  }
};

TEST_P(NoDevice, ExitsWithAClearMessageWithinSeconds) {
  const RunResult r = runCamera(std::string("--backend ") + GetParam());
  EXPECT_EQ(r.exit_code, 2) << r.stderr_text;  // 124 would mean the timeout killed it
  EXPECT_LT(r.seconds, 10.0);
  EXPECT_NE(r.stderr_text.find("no usable"), std::string::npos) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find(GetParam()), std::string::npos) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("found"), std::string::npos) << r.stderr_text;
}

INSTANTIATE_TEST_SUITE_P(Backends, NoDevice, ::testing::Values("freenect", "openni2"));

TEST(NoDeviceOptions, BadOptionsAreRejectedBeforeTouchingDevices) {
  const RunResult r = runCamera("--backend kinect2");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.stderr_text.find("--backend takes openni2 or freenect"), std::string::npos)
      << r.stderr_text;
  const RunResult c = runCamera("--backend freenect --calib /nonexistent/calib_params.xml");
  EXPECT_EQ(c.exit_code, 1);
  EXPECT_NE(c.stderr_text.find("calibration file"), std::string::npos) << c.stderr_text;
  EXPECT_NE(c.stderr_text.find("/nonexistent/calib_params.xml"), std::string::npos) << c.stderr_text;
  const RunResult e = runCamera("--backend openni2 --depth-encoding jpeg");
  EXPECT_EQ(e.exit_code, 1);
}

}  // namespace
