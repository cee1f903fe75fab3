#pragma once
/// \file
/// The exchange's state as the RT loop publishes it once a period (at
/// write()), for the other threads: health(), fault clear, the tests. A
/// single-writer seqlock (rt/seqlock.hpp): the loop never waits, a reader
/// copies and retries. The fault is kept as its figures (codes, bytes,
/// counts) and put in words only when read, off the RT path.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "drivers/canopen/cyclic_exchange.hpp"
#include "rt/seqlock.hpp"

namespace hapticd::drivers::canopen {

/// What the loop published last.
struct ExchangeStatus {
  bool faulted = false;
  bool resetting = false;    ///< a fault reset is running
  bool operational = false;  ///< Operation Enabled, no fault latched, no reset running
  std::string fault_reason;  ///< the drive's own words, "" if none
  FaultKind fault_kind = FaultKind::none;
  std::uint16_t statusword = 0;      ///< CiA 402 0x6041, the newest TPDO1's
  std::string drive_state;           ///< "Operation Enabled", ... ("unknown": no row of the table)
  std::uint16_t controlword = 0;     ///< CiA 402 0x6040, the last RPDO1's
  std::int16_t torque_permille = 0;  ///< CiA 402 0x6071, the last RPDO1's
  CyclicCounters counters;
};

struct PublishedCells;  ///< the seqlock's data (exchange_status.cpp)

class PublishedExchange {
 public:
  PublishedExchange();
  ~PublishedExchange();
  PublishedExchange(const PublishedExchange&) = delete;
  PublishedExchange& operator=(const PublishedExchange&) = delete;

  /// RT (the loop's write(), or the thread running periods before it runs):
  /// no allocation, no lock.
  void publish(const CyclicExchange& exchange) noexcept;
  /// How many publications so far (acquire): one per write().
  std::uint64_t publications() const noexcept { return publications_.load(std::memory_order_acquire); }
  /// Any non-RT thread: the last publication, the fault in words.
  ExchangeStatus load(const CyclicSettings& settings) const;

 private:
  std::unique_ptr<PublishedCells> cells_;
  rt::SeqlockVersion version_;
  std::atomic<std::uint64_t> publications_{0};
};

}  // namespace hapticd::drivers::canopen
