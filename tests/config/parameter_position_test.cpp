// Scene, device and hand-script errors found after parsing are reported at
// the exact file:line:column of the key they are about. The key comes with
// the error (world::SceneError / PlanRefusal::parameter,
// drivers::loopback::ParameterError), or, for a set refused as a whole,
// is the one given parameter without which the set plans and is stable;
// never from reading the message.
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "daemon/config/config.hpp"
#include "daemon/service.hpp"

namespace hapticd::daemon::parameter_position_test {
namespace {

namespace fs = std::filesystem;

struct Refusal {
  std::string where;  ///< "file:line:column", or "accepted"
  std::string key;
  std::string message;
};

/// Builds the service (what --check-config and start-up do) from `toml`.
Refusal refusal_of(const std::string& toml) {
  const fs::path dir = fs::temp_directory_path() / ("hapticd-position-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  ServiceOptions options;
  try {
    options.config =
        config::parse_config(toml + "\n[recorder]\ndirectory = \"" + dir.string() + "\"\n", "t.toml");
    Service service(std::move(options));
  } catch (const config::ConfigError& e) {
    return {e.where().to_string(), e.key(), e.what()};
  }
  return {"accepted", "", ""};
}

TEST(ParameterPositions, SceneBuildFailureIsAtTheParameterNotAtTheName) {
  // Was "t.toml:2:8: spring-wheel: discretized spring does not keep [y, 0] at
  // rest": no key, the position of name.
  const Refusal stiff = refusal_of("[scene]\nname = \"spring-wheel\"\nstiffness = 1e308\n");
  EXPECT_EQ(stiff.where, "t.toml:3:13") << stiff.message;
  EXPECT_EQ(stiff.key, "scene.stiffness");
  // Since the catalog's ranges (issue6-gate) the value is refused as out of
  // range, not as a failed build: the position is what this test is about.
  EXPECT_EQ(stiff.message.rfind("t.toml:3:13: ", 0), 0u) << stiff.message;
  EXPECT_NE(stiff.message.find("1e+09"), std::string::npos) << stiff.message;
  const Refusal light =
      refusal_of("[scene]\nname = \"spring-wheel\"\nintegrator = \"exact\"\ninertia = 1e-300\n");
  EXPECT_EQ(light.where, "t.toml:4:11") << light.message;
  EXPECT_EQ(light.key, "scene.inertia");
}

TEST(ParameterPositions, ValidationErrorIsAtTheKeyTheCatalogNames) {
  // "damping" is a substring of "damping_reference" and comes first in the
  // file: a search of the message blamed line 3.
  const Refusal r =
      refusal_of("[scene]\nname = \"spring-wheel\"\ndamping = 0.01\ndamping_reference = \"sideways\"\n");
  EXPECT_EQ(r.where, "t.toml:4:21") << r.message;
  EXPECT_EQ(r.key, "scene.damping_reference");
  const Refusal unknown = refusal_of("[scene]\nname = \"wall\"\nstiffness = 100\nstiff = 1\n");
  EXPECT_EQ(unknown.where, "t.toml:4:9") << unknown.message;
  EXPECT_EQ(unknown.key, "scene.stiff");
}

TEST(ParameterPositions, UnstableSetIsAtTheParameterThatMakesItUnstable) {
  const std::string device =
      "[device]\ntorque_limit = 20.0\n[device.loopback]\nmotion = \"linear\"\nmass = 0.1\n";
  // Hulin's wall at K = 20 kN/m (alpha = 2): the stiffness, not the damping
  // written before it.
  const Refusal wall =
      refusal_of(device + "[scene]\nname = \"wall\"\ndamping = 46.0\nstiffness = 20000.0\ndelay = 1\n");
  EXPECT_EQ(wall.where, "t.toml:9:13") << wall.message;
  EXPECT_EQ(wall.key, "scene.stiffness");
  EXPECT_NE(wall.message.find("largest stable K"), std::string::npos) << wall.message;
  // Forward Euler without damping (Freudenberg Fig. 8): the integrator.
  const Refusal euler =
      refusal_of("[scene]\nname = \"spring-wheel\"\nstiffness = 2\nintegrator = \"forward-euler\"\n");
  EXPECT_EQ(euler.where, "t.toml:4:14") << euler.message;
  EXPECT_EQ(euler.key, "scene.integrator");
}

TEST(ParameterPositions, ForceOfTheWrongTypeIsAtForce) {
  const Refusal r = refusal_of("[scene]\nname = \"spring-wheel\"\nforce = \"yes\"\n");
  EXPECT_EQ(r.where, "t.toml:3:9") << r.message;
  EXPECT_EQ(r.key, "scene.force");
}

TEST(ParameterPositions, DeviceErrorIsAtTheKeyTheDriverNames) {
  // "mass" is a substring of "motor_mass" and comes first in the file.
  const Refusal r = refusal_of("[device.loopback]\nplant = \"two-mass\"\nmass = 1\nmotor_mass = 0\n");
  EXPECT_EQ(r.where, "t.toml:4:14") << r.message;
  EXPECT_EQ(r.key, "device.loopback.motor_mass");
  // The registry's message (drivers/parameter.hpp) names the dotted key and the range.
  EXPECT_NE(r.message.find("device.loopback.motor_mass = 0 is out of range; accepted: a number in [1e-09"),
            std::string::npos)
      << r.message;
  const Refusal unknown = refusal_of("[device.loopback]\nmass = 1\nmas = 2\n");
  EXPECT_EQ(unknown.where, "t.toml:3:7") << unknown.message;
  EXPECT_EQ(unknown.key, "device.loopback.mas");
}

TEST(ParameterPositions, HandScriptErrorIsAtTheHandKey) {
  // hand.damping = -1: "damping" is also a loopback key, and "mode" was
  // blamed for any message mentioning a mode.
  const Refusal r = refusal_of(
      "[device.loopback]\ndamping = 0.002\n[device.loopback.hand]\nmode = \"impedance\"\nstiffness = 10\n"
      "damping = -1\n");
  EXPECT_EQ(r.where, "t.toml:6:11") << r.message;
  EXPECT_EQ(r.key, "device.loopback.hand.damping");
  // A missing key is blamed on the key that asks for it.
  const Refusal missing = refusal_of("[device.loopback.hand]\nmode = \"hold\"\ntrajectory = \"step\"\n");
  EXPECT_EQ(missing.where, "t.toml:3:14") << missing.message;
  EXPECT_EQ(missing.key, "device.loopback.hand.trajectory");
  // The one-string form: the string.
  const Refusal text = refusal_of("[device.loopback]\nmass = 0.01\nhand = \"mode=hold amplitude=x\"\n");
  EXPECT_EQ(text.where, "t.toml:3:8") << text.message;
  EXPECT_EQ(text.key, "device.loopback.hand");
}

TEST(ParameterPositions, AValidConfigIsAccepted) {
  EXPECT_EQ(refusal_of("[scene]\nname = \"spring-wheel\"\nstiffness = 2\n").where, "accepted");
}

}  // namespace
}  // namespace hapticd::daemon::parameter_position_test
