// End-to-end: bad input is refused, not read wrongly (issue 17, defects 10
// and 11), against the real hapticd on the loopback wheel: unknown members
// of every method, duplicate members, out-of-range and wrong-typed members,
// recording names with control characters, `hapticd --list-scenes --json`,
// and the numbers in an unstable set's refusal.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::refusal_test {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

// The default loopback wheel on the real clock; overruns never latch (the VM is noisy).
const std::string config = R"(
[loop]
period = "1ms"
clock = "real"
overrun_limit = 0

[device]
driver = "loopback"
torque_limit = 1.0

[scene]
name = "spring-wheel"
)";

/// The reply to one raw request line, on a fresh connection.
json ask(const Daemon& d, const std::string& line) {
  RawConnection c(d.socket());
  EXPECT_TRUE(c.send(line + "\n"));
  const std::string reply = c.read_line();
  return reply.empty() ? json() : json::parse(reply, nullptr, false);
}

json call(const Daemon& d, const std::string& method, const json& params) {
  return ask(d, json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", method}, {"params", params}}.dump());
}

std::string message_of(const json& reply) {
  return reply.contains("error") ? reply["error"].value("message", std::string()) : std::string("no error");
}

json status(const Daemon& d) { return json::parse(d.ctl({"status", "--json"}).out, nullptr, false); }

/// Every method docs/protocol.md documents ("### name (R|W ...)").
std::vector<std::string> documented_methods() {
  std::ifstream in(fs::path(HAPTICD_SOURCE_DIR) / "docs/protocol.md");
  const std::regex heading(R"(^### ([a-z][a-z0-9._]*) \()");
  std::vector<std::string> names;
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, heading)) names.push_back(m[1]);
  }
  return names;
}

// Issue 17, defect 10: scene.load {"parameters": ...} (a misspelt "params")
// loaded the defaults. Every method, the daemon's and the loopback
// driver's, refuses a member it does not take with -32602 naming it; a
// method of another driver is not there (-32601). estop stops first, then
// says so.
TEST(Refusals, EveryMethodRefusesAMemberItDoesNotTake) {
  TempDir dir;
  Daemon d(dir, config);
  ASSERT_TRUE(d.running()) << d.log();
  const auto methods = documented_methods();
  ASSERT_GE(methods.size(), 20u) << "docs/protocol.md's method headings not found";
  int refused = 0;
  for (const auto& method : methods) {
    json reply = call(d, method, {{"zz_not_a_member", 1}});
    if (reply["error"]["code"] == -32601) {
      EXPECT_TRUE(method.starts_with("device.sdo.")) << method << " is missing on the loopback";
      continue;
    }
    EXPECT_EQ(reply["error"]["code"], -32602) << method << ": " << reply.dump();
    EXPECT_NE(message_of(reply).find("unknown member 'zz_not_a_member'"), std::string::npos)
        << method << ": " << reply.dump();
    EXPECT_EQ(reply["error"]["data"]["member"], "zz_not_a_member") << method << ": " << reply.dump();
    ++refused;
  }
  EXPECT_GE(refused, 18);
  // Nothing acted but estop, which stops whatever it is sent.
  json s = status(d);
  EXPECT_EQ(s["fault"], "estop") << s.dump();
  EXPECT_EQ(s["scene"]["name"], "spring-wheel");
  EXPECT_FALSE(s["recording"]["active"].get<bool>());
  EXPECT_EQ(d.ctl({"fault", "clear"}).exit_code, 0);
  EXPECT_TRUE(d.running()) << d.log();
}

TEST(Refusals, SceneLoadWithAMisspeltParamsIsRefusedNotLoadedWithDefaults) {
  TempDir dir;
  Daemon d(dir, config);
  ASSERT_TRUE(d.running()) << d.log();
  json reply = call(d, "scene.load", {{"scene", "wall"}, {"parameters", {{"stiffness", 5000}}}});
  EXPECT_EQ(reply["error"]["code"], -32602) << reply.dump();
  EXPECT_EQ(message_of(reply), "scene.load: unknown member 'parameters'; accepted: scene, params, force");
  EXPECT_EQ(status(d)["scene"]["name"], "spring-wheel") << "the wall was loaded with its defaults";
  // The envelope too: a misspelt "params" of the request itself.
  json envelope = ask(d, R"({"jsonrpc":"2.0","id":2,"method":"scene.load","parmas":{"scene":"wall"}})");
  EXPECT_EQ(envelope["error"]["code"], -32600) << envelope.dump();
  EXPECT_NE(message_of(envelope).find("'parmas'"), std::string::npos) << envelope.dump();
  EXPECT_EQ(status(d)["scene"]["name"], "spring-wheel");
}

// Issue 17, defect 10: {"method":"status","method":"estop"} ran estop.
TEST(Refusals, ADuplicateMemberIsRefusedAndRunsNothing) {
  TempDir dir;
  Daemon d(dir, config);
  ASSERT_TRUE(d.running()) << d.log();
  json reply = ask(d, R"({"jsonrpc":"2.0","id":1,"method":"status","method":"estop"})");
  EXPECT_EQ(reply["error"]["code"], -32600) << reply.dump();
  EXPECT_NE(message_of(reply).find("'method' appears twice"), std::string::npos) << reply.dump();
  json nested = ask(
      d,
      R"({"jsonrpc":"2.0","id":1,"method":"scene.load","params":{"scene":"wall","params":{"stiffness":100,"stiffness":9e9}}})");
  EXPECT_EQ(nested["error"]["code"], -32600) << nested.dump();
  json s = status(d);
  EXPECT_TRUE(s["fault"].is_null()) << "estop ran: " << s.dump();
  EXPECT_EQ(s["scene"]["name"], "spring-wheel");
}

// Issue 17, defect 10: fault.inject amounts 2^64-1, -2 and 2^63 were
// reinterpreted (-1: until cleared), and two encoder jumps of 2^63-1
// wrapped to -2. Out of range is refused, naming the range.
TEST(Refusals, FaultInjectAmountsOutOfRangeAreRefusedNamingTheRange) {
  TempDir dir;
  Daemon d(dir, config);
  ASSERT_TRUE(d.running()) << d.log();
  for (const char* amount : {"18446744073709551615", "-2", "9223372036854775808", "0"}) {
    json reply = ask(
        d,
        std::string(R"({"jsonrpc":"2.0","id":1,"method":"fault.inject","params":{"kind":"stall","amount":)") +
            amount + "}}");
    EXPECT_EQ(reply["error"]["code"], -32602) << amount << ": " << reply.dump();
    EXPECT_NE(message_of(reply).find("must be an integer from 1 to 9223372036854775807 periods, or -1"),
              std::string::npos)
        << amount << ": " << reply.dump();
  }
  EXPECT_TRUE(status(d)["device"]["fault_reason"].is_null()) << "a fault was injected";
  json huge = call(d, "fault.inject", {{"kind", "encoder-jump"}, {"amount", 9223372036854775807LL}});
  EXPECT_EQ(huge["error"]["code"], -32602) << huge.dump();
  EXPECT_NE(message_of(huge).find("from -9007199254740992 to 9007199254740992"), std::string::npos)
      << huge.dump();
  // Jumps add up: the one that would take the offset past 2^53 is refused.
  const std::int64_t half = std::int64_t{1} << 52;
  EXPECT_EQ(call(d, "fault.inject", {{"kind", "encoder-jump"}, {"amount", half}})["result"]["amount"], half);
  EXPECT_EQ(call(d, "fault.inject", {{"kind", "encoder-jump"}, {"amount", half}})["result"]["amount"], half);
  json third = call(d, "fault.inject", {{"kind", "encoder-jump"}, {"amount", 1}});
  EXPECT_EQ(third["error"]["code"], -32602) << third.dump();
  EXPECT_NE(message_of(third).find("would take the offset from 9007199254740992 to 9007199254740993"),
            std::string::npos)
      << third.dump();
  EXPECT_EQ(d.ctl({"fault", "clear"}).exit_code, 0);
  EXPECT_EQ(call(d, "fault.inject", {{"kind", "stall"}, {"amount", -1}})["result"]["amount"], -1);
  EXPECT_EQ(d.ctl({"fault", "clear"}).exit_code, 0);
  EXPECT_TRUE(d.running()) << d.log();
}

// Issue 17, defect 10: record.start {"path":5} and fault.inject {"kind":1}
// answered with nlohmann's internal type error.
TEST(Refusals, AWrongTypedMemberNamesTheMemberAndTheType) {
  TempDir dir;
  Daemon d(dir, config);
  ASSERT_TRUE(d.running()) << d.log();
  json path = call(d, "record.start", {{"path", 5}});
  EXPECT_EQ(path["error"]["code"], -32602) << path.dump();
  EXPECT_EQ(message_of(path), "record.start: member 'path' must be a string, not an integer (5)");
  json kind = call(d, "fault.inject", {{"kind", 1}});
  EXPECT_EQ(kind["error"]["code"], -32602) << kind.dump();
  EXPECT_EQ(message_of(kind), "fault.inject: member 'kind' must be a string, not an integer (1)");
  json force = call(d, "param.set", {{"params", {{"stiffness", 2}}}, {"force", "yes"}});
  EXPECT_EQ(message_of(force), "param.set: member 'force' must be true or false, not a string (\"yes\")");
  json names = call(d, "param.get", {{"names", "stiffness"}});
  EXPECT_EQ(message_of(names), "param.get: member 'names' must be an array, not a string (\"stiffness\")");
  json reset = call(d, "stats.reset", {{"x", 1}});
  EXPECT_EQ(message_of(reset), "stats.reset: unknown member 'x'; stats.reset accepts no members");
}

// Issue 17, defect 10: a recording name with a newline or a carriage return
// was taken (and broke every line that shows it).
TEST(Refusals, RecordingNamesWithControlCharactersAreRefused) {
  TempDir dir;
  Daemon d(dir, config);
  ASSERT_TRUE(d.running()) << d.log();
  for (const std::string name : {"a\nb.csv", "a\rb.csv", "tab\there.csv", "esc\x1b[31m.csv", "del\x7f.csv"}) {
    json reply = call(d, "record.start", {{"path", name}});
    EXPECT_EQ(reply["error"]["code"], -32000) << reply.dump();
    const std::string message = message_of(reply);
    EXPECT_NE(message.find("control characters"), std::string::npos) << message;
    EXPECT_EQ(message.find_first_of("\n\r\t\x1b\x7f"), std::string::npos) << "the name raw in the message";
  }
  for (const auto& entry : fs::directory_iterator(dir.path))
    EXPECT_EQ(entry.path().extension() == ".csv", false) << "created " << entry.path();
  EXPECT_FALSE(status(d)["recording"]["active"].get<bool>());
  EXPECT_EQ(d.ctl({"record", "start", "--path", "fine.csv"}).exit_code, 0);
  EXPECT_EQ(d.ctl({"record", "stop"}).exit_code, 0);
}

// Issue 17, defect 10: `hapticd --list-scenes --json` printed text. It is
// scene.list's result now (units for --motion; "current" null: no daemon).
TEST(Refusals, ListScenesJsonIsSceneListsJson) {
  TempDir dir;
  Daemon d(dir, config);
  ASSERT_TRUE(d.running()) << d.log();
  json listed = call(d, "scene.list", json::object())["result"];
  const auto rotary = run(hapticd_binary(), {"--list-scenes", "--json", "--motion", "rotary"});
  ASSERT_EQ(rotary.exit_code, 0) << rotary.err;
  json offline = json::parse(rotary.out, nullptr, false);
  ASSERT_TRUE(offline.is_object()) << rotary.out;
  EXPECT_EQ(offline["scenes"], listed["scenes"]) << "not the same as scene.list on the loopback wheel";
  EXPECT_TRUE(offline["current"].is_null());
  const auto linear = run(hapticd_binary(), {"--list-scenes", "--json"});
  json by_default = json::parse(linear.out, nullptr, false);
  ASSERT_TRUE(by_default.is_object()) << linear.out;
  for (const auto& scene : by_default["scenes"]) {
    if (scene["name"] != "wall") continue;
    EXPECT_EQ(scene["parameters"][0]["unit"], "N/m") << "linear units by default";
  }
  const auto drivers = run(hapticd_binary(), {"--list-drivers", "--json"});
  EXPECT_TRUE(json::parse(drivers.out, nullptr, false).is_array()) << drivers.out;
  const auto bad = run(hapticd_binary(), {"--list-scenes", "--json", "--motion", "sideways"});
  EXPECT_EQ(bad.exit_code, 2) << bad.out << bad.err;
}

// Issue 17, defect 11: the default wall on the loopback wheel was refused
// with "amplitude grows x2.099e+303 per second" and growth_per_second
// 2.0991525899817493e+303. hapticctl's refusal now says how soon the
// amplitude doubles, and the reply's figures are finite or null.
TEST(Refusals, AnUnstableWallsRefusalReadsAsADoublingTime) {
  TempDir dir;
  Daemon d(dir, config);
  ASSERT_TRUE(d.running()) << d.log();
  const auto load = d.ctl({"load", "wall", "stiffness=9000"});
  EXPECT_EQ(load.exit_code, 1) << load.out << load.err;
  EXPECT_NE(load.err.find("the amplitude doubles every 992 us (x2.011 per period of 1 ms)"),
            std::string::npos)
      << load.err;
  EXPECT_EQ(load.err.find("e+30"), std::string::npos) << load.err;
  json reply = call(d, "scene.load", {{"scene", "wall"}, {"params", {{"stiffness", 9000}}}});
  json stability = reply["error"]["data"]["stability"];
  EXPECT_TRUE(stability["growth_per_second"].is_null()) << stability.dump();
  EXPECT_NEAR(stability["growth_per_second_log10"].get<double>(), 303.32, 0.01) << stability.dump();
  EXPECT_NEAR(stability["doubling_time_s"].get<double>(), 992.4e-6, 0.1e-6) << stability.dump();
  EXPECT_EQ(status(d)["scene"]["name"], "spring-wheel");
}

}  // namespace
}  // namespace hapticd::e2e::refusal_test
