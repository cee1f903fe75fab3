#include "drivers/canopen/can_error.hpp"

#include <linux/can.h>
#include <linux/can/error.h>

#include <cstdio>
#include <utility>

namespace hapticd::drivers::canopen {

static_assert(cia301::can_err_flag == CAN_ERR_FLAG && cia301::can_eff_flag == CAN_EFF_FLAG &&
              cia301::can_rtr_flag == CAN_RTR_FLAG && cia301::can_sff_mask == CAN_SFF_MASK);

std::uint32_t subscribed_error_classes() noexcept {
  return CAN_ERR_TX_TIMEOUT | CAN_ERR_CRTL | CAN_ERR_ACK | CAN_ERR_BUSOFF | CAN_ERR_RESTARTED;
}

BusError decode_error_frame(const cia301::Frame& frame) noexcept {
  BusError e;
  if ((frame.id & CAN_ERR_FLAG) == 0) return e;
  e.classes = frame.id & CAN_ERR_MASK;
  e.controller = frame.len > 1 ? frame.data[1] : 0;
  constexpr std::uint32_t fatal_classes = CAN_ERR_BUSOFF | CAN_ERR_ACK | CAN_ERR_TX_TIMEOUT;
  constexpr std::uint8_t fatal_controller =
      CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW | CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE;
  const bool fatal = (e.classes & fatal_classes) != 0 ||
                     ((e.classes & CAN_ERR_CRTL) != 0 && (e.controller & fatal_controller) != 0);
  e.severity = fatal ? BusErrorSeverity::fault : BusErrorSeverity::notice;
  return e;
}

std::string describe(const BusError& error) {
  if (error.severity == BusErrorSeverity::none) return "";
  static constexpr std::pair<std::uint32_t, const char*> classes[] = {
      {CAN_ERR_BUSOFF, "bus-off"},
      {CAN_ERR_ACK, "no ACK on transmission (no other node on the bus?)"},
      {CAN_ERR_TX_TIMEOUT, "TX timeout"},
      {CAN_ERR_RESTARTED, "controller restarted"},
      {CAN_ERR_LOSTARB, "lost arbitration"},
      {CAN_ERR_PROT, "protocol violation"},
      {CAN_ERR_TRX, "transceiver status"},
      {CAN_ERR_BUSERROR, "bus error"},
  };
  static constexpr std::pair<std::uint8_t, const char*> controller[] = {
      {CAN_ERR_CRTL_RX_OVERFLOW, "RX buffer overflow"},
      {CAN_ERR_CRTL_TX_OVERFLOW, "TX buffer overflow"},
      {CAN_ERR_CRTL_RX_WARNING, "RX error warning level"},
      {CAN_ERR_CRTL_TX_WARNING, "TX error warning level"},
      {CAN_ERR_CRTL_RX_PASSIVE, "RX error passive"},
      {CAN_ERR_CRTL_TX_PASSIVE, "TX error passive"},
      {CAN_ERR_CRTL_ACTIVE, "back to error active"},
  };
  std::string out;
  auto add = [&out](const char* words) {
    if (!out.empty()) out += "; ";
    out += words;
  };
  for (const auto& [bit, words] : classes)
    if ((error.classes & bit) != 0) add(words);
  if ((error.classes & CAN_ERR_CRTL) != 0) {
    std::string details;
    for (const auto& [bit, words] : controller) {
      if ((error.controller & bit) == 0) continue;
      if (!details.empty()) details += ", ";
      details += words;
    }
    add(("controller problem: " + (details.empty() ? std::string("unspecified") : details)).c_str());
  }
  if (out.empty()) out = "error frame";
  return "CAN " + out;
}

std::string describe(const MalformedMessage& m) {
  if (m.bytes == sizeof(can_frame)) {
    char id[16];
    std::snprintf(id, sizeof id, "0x%03X", static_cast<unsigned>(m.can_id & CAN_EFF_MASK));
    return "a can_frame with len " + std::to_string(m.can_len) + " (id " + id +
           ") on the CAN socket: a classic frame carries 0..8 data bytes";
  }
  const std::string size = m.truncated ? "more than " + std::to_string(m.bytes) : std::to_string(m.bytes);
  return "a " + size + "-byte message on the CAN socket: not a can_frame (" +
         std::to_string(sizeof(can_frame)) + " bytes)";
}

}  // namespace hapticd::drivers::canopen
