// What the README says about allocation on the period path: hapticd's code
// allocates nothing (AllocationGuard, operator new), but libusb's Linux
// backend callocs one URB struct per submission (submit_bulk_transfer in
// libusb/os/linux_usbfs.c, used for interrupt transfers too) and frees it
// at reap. This counts the C allocations libusb itself makes on this
// thread, by interposing calloc/malloc in the test binary and asking
// dladdr() which library called.

#include <dlfcn.h>
#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>

#include "drivers/usb_hid/usb_hid_device.hpp"
#include "emulated_board_fixture.hpp"

extern "C" void* __libc_calloc(std::size_t, std::size_t);
extern "C" void* __libc_malloc(std::size_t);

namespace {
thread_local bool counting = false;
thread_local std::size_t libusb_allocations = 0;

bool called_from_libusb(void* return_address) {
  Dl_info info{};
  return dladdr(return_address, &info) != 0 && info.dli_fname != nullptr &&
         std::strstr(info.dli_fname, "libusb-1.0") != nullptr;
}
}  // namespace

extern "C" void* calloc(std::size_t n, std::size_t size) {
  if (counting) {
    counting = false;  // dladdr may allocate
    if (called_from_libusb(__builtin_return_address(0))) ++libusb_allocations;
    counting = true;
  }
  return __libc_calloc(n, size);
}

extern "C" void* malloc(std::size_t size) {
  if (counting) {
    counting = false;
    if (called_from_libusb(__builtin_return_address(0))) ++libusb_allocations;
    counting = true;
  }
  return __libc_malloc(size);
}

namespace hapticd::drivers::usb_hid {
namespace {

using testing::EmulatedBoardTest;

TEST_F(EmulatedBoardTest, LibusbCallocsOneUrbPerSubmission) {
  UsbHidConfig config;
  config.selector.vendor_id = 0x1209;
  config.selector.product_id = 0x0001;
  UsbHidDevice link(config);
  link.configure({1e-3});
  link.enable();
  Reading r;
  ASSERT_EQ(link.read(r), IoResult::ok);
  ASSERT_EQ(link.write(0.0), IoResult::ok);
  constexpr int periods = 100;
  int not_ok = 0;
  libusb_allocations = 0;  // this run's only (--gtest_repeat)
  counting = true;
  for (int p = 0; p < periods; ++p) {
    not_ok += link.read(r) != IoResult::ok;
    not_ok += link.write(0.1) != IoResult::ok;
  }
  counting = false;
  EXPECT_EQ(not_ok, 0) << "read/write calls that were not ok";
  // Per period: the IN transfer resubmitted in its callback and the OUT
  // transfer: two submissions, two URB callocs, nothing else from libusb.
  EXPECT_EQ(libusb_allocations, 2U * periods);
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid
