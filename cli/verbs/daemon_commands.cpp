// add_daemon_commands: every daemon verb in one call for cli/main.cpp.

#include "cli/verbs.hpp"

namespace hapticctl {

void add_daemon_commands(CLI::App& app, CommonOptions& opts) {
  add_common_options(app, opts);
  add_status_command(app, opts);
  add_scenes_command(app, opts);
  add_load_command(app, opts);
  add_get_command(app, opts);
  add_set_command(app, opts);
  add_record_command(app, opts);
  add_stream_command(app, opts);
  add_hand_command(app, opts);
  add_fault_command(app, opts);
  add_estop_command(app, opts);
  add_stats_command(app, opts);
  add_device_command(app, opts);
  add_telemetry_command(app, opts);
}

}  // namespace hapticctl
