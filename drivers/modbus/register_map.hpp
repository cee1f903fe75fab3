#pragma once
/// \file
/// The amplifier's register map and the two blocks exchanged every period:
/// the write block (torque command, and the watchdog register when it sits
/// next to it) and the read block (the span covering position, velocity,
/// status and fault registers). Encoding, decoding, 32-bit word order and
/// status/fault bit meanings. Pure code; encode/decode are RT-safe (no
/// allocation, no text).
///
/// Addresses are PDU addresses, 0-based, as on the wire (V1.1b3 4.4: the
/// "holding register 40001" of a manual is PDU address 0). Each register is
/// sent big-endian (high byte first, V1.1b3 4.2); a 32-bit value over two
/// registers has no standard order, hence `word_order`.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace hapticd::drivers::modbus {

/// Which register of a 32-bit pair holds the high 16 bits.
enum class WordOrder : std::uint8_t {
  high_first,  ///< register n = bits 31..16, n+1 = bits 15..0 ("ABCD", big-endian words)
  low_first,   ///< register n = bits 15..0, n+1 = bits 31..16 ("CDAB", word-swapped)
};

/// Holding registers (read with fc 3 or 23) or input registers (fc 4 only).
enum class ReadTable : std::uint8_t { holding, input };

/// How the power stage is switched.
enum class EnableKind : std::uint8_t {
  none,          ///< the amplifier is enabled by other means (a hardware input)
  coil,          ///< a coil written with fc 5 (FF00 on, 0000 off)
  register_bit,  ///< one bit of a holding register, read-modify-write with fc 3 + fc 6
};

/// How the amplifier's watchdog is kept alive once armed.
enum class WatchdogRefresh : std::uint8_t {
  write,      ///< the watchdog register is rewritten every period (it must sit next to the torque register)
  any_frame,  ///< the amplifier restarts its timer on every valid frame: armed at configure only
  counter,    ///< an alive counter: one more every exchange, 0xFFFF -> 0 (next to the torque register too)
};

/// The watchdog register sits in the periodic write block (write, counter).
constexpr bool written_every_period(WatchdogRefresh refresh) noexcept {
  return refresh != WatchdogRefresh::any_frame;
}

struct FaultBit {
  int bit = 0;       ///< 0..15
  std::string name;  ///< "over-current"
};

struct RegisterMap {
  std::uint16_t position = 0;  ///< first of two registers, signed 32-bit counts
  WordOrder word_order = WordOrder::high_first;
  std::optional<std::uint16_t> velocity;  ///< first of two registers, signed 32-bit counts/s
  std::uint16_t torque = 0;               ///< signed 16-bit command counts
  std::optional<std::uint16_t> watchdog;  ///< written with watchdog_value at configure and every period
  std::uint16_t watchdog_value = 0;       ///< counter: the counter's first value
  WatchdogRefresh watchdog_refresh = WatchdogRefresh::write;
  EnableKind enable = EnableKind::none;
  std::uint16_t enable_address = 0;
  int enable_bit = 0;  ///< register_bit only
  std::optional<std::uint16_t> status;
  int status_enabled_bit = -1;  ///< -1: the status register does not say
  int status_fault_bit = -1;
  std::optional<std::uint16_t> fault;  ///< nonzero = in fault
  std::vector<FaultBit> fault_bits;
  std::optional<std::uint16_t> reset;  ///< written with reset_value by `fault clear`
  std::uint16_t reset_value = 1;
  ReadTable read_table = ReadTable::holding;
};

/// Where each value sits inside the two periodic blocks.
struct BlockLayout {
  std::uint16_t write_address = 0;
  std::uint16_t write_count = 0;
  int torque_index = 0;
  int watchdog_index = -1;  ///< -1: the watchdog is not in the write block (none, or armed only)
  std::uint16_t read_address = 0;
  std::uint16_t read_count = 0;
  int position_index = 0;
  int velocity_index = -1;
  int status_index = -1;
  int fault_index = -1;
};

/// plan_blocks() result: the layout, or the key to blame and why.
struct LayoutResult {
  BlockLayout layout;
  std::string error_key;  ///< "" when the map is usable
  std::string error;
};

/// Builds the blocks. The write block is the torque register, plus the
/// watchdog register with refresh = write, which must then be adjacent (fc
/// 16/23 write one contiguous range). The read block spans position,
/// velocity, status and fault (gaps are read too); it must fit one request
/// (125 registers) and its items must not overlap.
LayoutResult plan_blocks(const RegisterMap& map);

/// Splits / joins a 32-bit value over two registers.
void split_words(std::int32_t value, WordOrder order, std::uint16_t& first, std::uint16_t& second) noexcept;
std::int32_t join_words(std::uint16_t first, std::uint16_t second, WordOrder order) noexcept;

/// One decoded read block.
struct AmplifierSample {
  std::int32_t position_counts = 0;
  std::int32_t velocity_counts = 0;  ///< 0 without a velocity register
  std::uint16_t status = 0;
  std::uint16_t fault = 0;
  bool enabled = false;  ///< status says the power stage is on (true when the map has no such bit)
  bool faulted = false;  ///< status fault bit set, or the fault register nonzero
};

/// Fills the write block (`out` has layout.write_count registers).
void encode_command(const BlockLayout& layout, std::int16_t torque_counts, std::uint16_t watchdog_value,
                    std::span<std::uint16_t> out) noexcept;
/// Decodes the read block (`block` has layout.read_count registers).
AmplifierSample decode_sample(const RegisterMap& map, const BlockLayout& layout,
                              std::span<const std::uint16_t> block) noexcept;

/// Torque command counts for `torque` (N m or N) at `per_count`, rounded to
/// nearest and clamped to int16; `saturated` says whether it was clamped.
std::int16_t torque_counts(double torque, double per_count, bool& saturated) noexcept;

/// The fault word in words, non-RT: "over-current, bit 7 (fault register 0x0081)".
std::string describe_faults(std::uint16_t fault_word, const std::vector<FaultBit>& bits);

/// Parses "0:over-current,1:over-voltage" (bit:name pairs, comma separated).
/// Throws std::invalid_argument naming the bad item and the accepted form.
std::vector<FaultBit> parse_fault_bits(const std::string& text);
std::string format_fault_bits(const std::vector<FaultBit>& bits);

}  // namespace hapticd::drivers::modbus
