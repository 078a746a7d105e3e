// reuse_freed_memory: a large block the process frees stays in its heap for the next allocation
// (glibc would otherwise have mapped it on its own and unmapped it at free). Its own executable:
// the call changes the allocator of the whole process.
#include <gshell/run/process_memory.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <utility>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace {

#if defined(__GLIBC__)
TEST(ProcessMemory, AFreedLargeBlockStaysInTheHeap) {
  constexpr std::size_t kBlock = std::size_t{64} << 20; // above glibc's largest mmap threshold
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer has its own allocator: glibc's heap statistics say nothing";
#endif
  // Allocates, touches and frees one block; returns the bytes of mapped blocks the free gave
  // back and the free bytes left in the heap.
  auto free_a_block = [&] {
    void* block = std::malloc(kBlock);
    EXPECT_NE(block, nullptr);
    std::memset(block, 1, kBlock);
    const std::size_t mapped_before = mallinfo2().hblkhd;
    std::free(block);
    return std::pair<std::size_t, std::size_t>{mapped_before - mallinfo2().hblkhd, mallinfo2().fordblks};
  };
  EXPECT_GE(free_a_block().first, kBlock) << "glibc's default maps such a block on its own";
  gshell::reuse_freed_memory();
  const auto [unmapped, free_in_heap] = free_a_block();
  EXPECT_EQ(unmapped, 0u);
  EXPECT_GE(free_in_heap, kBlock);
}

// A block another thread asks for after the main thread freed a larger one comes from the freed
// one's place (with glibc's default that thread gets an arena of its own, elsewhere, and touches
// fresh pages). Threads started before reuse_freed_memory keep their arenas: none is here.
TEST(ProcessMemory, AnotherThreadReusesAFreedBlock) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer has its own allocator";
#endif
  gshell::reuse_freed_memory();
  constexpr std::size_t kFreed = std::size_t{32} << 20, kAsked = std::size_t{16} << 20;
  void* freed = std::malloc(kFreed);
  ASSERT_NE(freed, nullptr);
  std::memset(freed, 1, kFreed);
  const auto begin = reinterpret_cast<std::uintptr_t>(freed);
  std::free(freed);
  std::uintptr_t asked = 0;
  std::thread([&] {
    void* block = std::malloc(kAsked);
    asked = reinterpret_cast<std::uintptr_t>(block);
    std::free(block);
  }).join();
  EXPECT_GE(asked, begin);
  EXPECT_LE(asked + kAsked, begin + kFreed);
}
#endif

} // namespace
