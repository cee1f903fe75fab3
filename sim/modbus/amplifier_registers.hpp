#pragma once
/// \file
/// The register map of the amplifier hapticd-devsim simulates, as its own
/// manual gives it. Written here, not taken from the driver's
/// register_map.*: a driver that reads the map or the protocol wrongly then
/// fails against it instead of agreeing with itself.
///
/// Addresses are PDU addresses, 0-based (Modbus Application Protocol
/// V1.1b3, 4.4: a manual's "holding register 40001" is address 0). Every
/// register is 16 bits, high byte first on the wire (4.2).
///
///   0-1  position, counts, signed 32 bits          read
///   2-3  velocity, counts/s, signed 32 bits        read
///   4    status: bit 0 power stage on, bit 1 fault read
///   5    fault word (fault_bit below)              read
///   10   torque command, counts, signed 16 bits    write
///   11   watchdog: ms, 0 disarms (or an alive counter)  write
///   12   control word: bit 0 enables               write (or coil 12)
///   13   fault reset: write 1                      write
///
/// What a real amplifier lets its owner choose, the simulated one takes as
/// settings (AmplifierSettings, amplifier.hpp): which of the two position
/// registers holds the high word, whether the state (0-5) sits in the
/// holding or the input registers, whether coil 12 or the control word's
/// bit switches the power stage, and how its watchdog is kept alive.

#include <cstdint>

namespace hapticd::drivers::modbus::sim {

namespace amplifier_register {
inline constexpr std::uint16_t position = 0;  ///< and 1
inline constexpr std::uint16_t velocity = 2;  ///< and 3
inline constexpr std::uint16_t status = 4;
inline constexpr std::uint16_t fault = 5;
inline constexpr std::uint16_t torque = 10;
inline constexpr std::uint16_t watchdog = 11;
inline constexpr std::uint16_t control = 12;
inline constexpr std::uint16_t reset = 13;
}  // namespace amplifier_register

/// Coil 12 switches the power stage when the amplifier is set to enable by coil.
inline constexpr std::uint16_t enable_coil = 12;
/// The value of register 13 that clears the fault word.
inline constexpr std::uint16_t reset_command = 1;

namespace status_bit {
inline constexpr unsigned enabled = 0;
inline constexpr unsigned fault = 1;
}  // namespace status_bit

namespace control_bit {
inline constexpr unsigned enable = 0;
}  // namespace control_bit

namespace fault_bit {
inline constexpr unsigned over_current = 0;
inline constexpr unsigned over_voltage = 1;
inline constexpr unsigned watchdog = 2;
inline constexpr unsigned following_error = 3;
inline constexpr unsigned over_temperature = 4;
}  // namespace fault_bit

/// Which register of the 32-bit pairs (position, velocity) holds bits 31..16.
enum class WordOrder32 : std::uint8_t { high_word_first, low_word_first };
/// Where the state registers 0-5 are: holding (read with fc 3 or 23) or input (fc 4).
enum class StateTable : std::uint8_t { holding, input };
/// What switches the power stage: the control word's bit 0, or coil 12 (fc 5).
enum class EnableBy : std::uint8_t { control_word, coil };

/// A signed 32-bit value as the two registers of a pair, in `order`.
struct RegisterPair {
  std::uint16_t first = 0, second = 0;
};
constexpr RegisterPair to_registers(std::int32_t value, WordOrder32 order) noexcept {
  const auto bits = static_cast<std::uint32_t>(value);
  const auto high = static_cast<std::uint16_t>(bits >> 16);
  const auto low = static_cast<std::uint16_t>(bits & 0xFFFFu);
  return order == WordOrder32::high_word_first ? RegisterPair{high, low} : RegisterPair{low, high};
}

}  // namespace hapticd::drivers::modbus::sim
