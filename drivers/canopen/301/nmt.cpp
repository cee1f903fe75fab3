#include "drivers/canopen/301/nmt.hpp"

#include "drivers/canopen/301/cob_id.hpp"

namespace hapticd::drivers::canopen::cia301 {

std::optional<NmtCommand> to_nmt_command(std::uint8_t cs) noexcept {
  switch (cs) {
    case 0x01:
    case 0x02:
    case 0x80:
    case 0x81:
    case 0x82:
      return static_cast<NmtCommand>(cs);
    default:
      return std::nullopt;
  }
}

std::string_view to_string(NmtCommand command) noexcept {
  switch (command) {
    case NmtCommand::start:
      return "start";
    case NmtCommand::stop:
      return "stop";
    case NmtCommand::enter_pre_operational:
      return "enter pre-operational";
    case NmtCommand::reset_node:
      return "reset node";
    case NmtCommand::reset_communication:
      return "reset communication";
  }
  return "unknown NMT command";
}

std::optional<NmtState> to_nmt_state(std::uint8_t value) noexcept {
  switch (value) {
    case 0x00:
    case 0x04:
    case 0x05:
    case 0x7F:
      return static_cast<NmtState>(value);
    default:
      return std::nullopt;
  }
}

std::string_view to_string(NmtState state) noexcept {
  switch (state) {
    case NmtState::boot_up:
      return "boot-up";
    case NmtState::stopped:
      return "stopped";
    case NmtState::operational:
      return "operational";
    case NmtState::pre_operational:
      return "pre-operational";
  }
  return "unknown NMT state";
}

Frame encode_nmt(NmtCommand command, std::uint8_t node) noexcept {
  Frame f;
  f.id = cob::nmt;
  f.len = 2;
  f.data[0] = static_cast<std::uint8_t>(command);
  f.data[1] = node;
  return f;
}

std::optional<NmtMessage> decode_nmt(const Frame& frame) noexcept {
  if (!is_standard_data_frame(frame) || frame.id != cob::nmt || frame.len != 2) return std::nullopt;
  const auto command = to_nmt_command(frame.data[0]);
  if (!command || frame.data[1] > max_node_id) return std::nullopt;
  return NmtMessage{*command, frame.data[1]};
}

Frame encode_heartbeat(std::uint8_t node, NmtState state) noexcept {
  Frame f;
  f.id = heartbeat_id(node);
  f.len = 1;
  f.data[0] = static_cast<std::uint8_t>(state);
  return f;
}

std::optional<Heartbeat> decode_heartbeat(const Frame& frame) noexcept {
  if (!is_standard_data_frame(frame) || frame.len != 1) return std::nullopt;
  const auto node = node_of(frame.id, cob::heartbeat);
  if (!node) return std::nullopt;
  const auto state = to_nmt_state(static_cast<std::uint8_t>(frame.data[0] & 0x7FU));
  if (!state) return std::nullopt;
  return Heartbeat{*node, *state};
}

Frame encode_sync() noexcept {
  Frame f;
  f.id = cob::sync;
  f.len = 0;
  return f;
}

Frame encode_sync(std::uint8_t counter) noexcept {
  Frame f = encode_sync();
  f.len = 1;
  f.data[0] = counter;
  return f;
}

bool is_sync(const Frame& frame) noexcept {
  return is_standard_data_frame(frame) && frame.id == cob::sync && frame.len <= 1;
}

}  // namespace hapticd::drivers::canopen::cia301
