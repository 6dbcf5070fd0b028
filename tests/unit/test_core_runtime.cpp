// The process-level helpers of appliance/core: the progress bar (drawn only on a terminal, at
// most every 100 ms, a final line only for work that lasted) and keep_freed_memory (large
// buffers come from the heap, not from a fresh mmap each time).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <malloc.h>
#include <pty.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "appliance/core/buffer.hpp"
#include "appliance/core/memory.hpp"
#include "appliance/core/progress.hpp"

namespace {

// Points stderr (fd 2) at `fd` for the life of the object.
class StderrTo {
public:
    explicit StderrTo(int fd) : saved_(::dup(2)) { ::dup2(fd, 2); }
    ~StderrTo() {
        ::dup2(saved_, 2);
        ::close(saved_);
    }

private:
    int saved_;
};

// What is waiting on `fd` (non-blocking), as text.
std::string drain(int fd) {
    ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
    std::string text;
    char buf[512];
    for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0;) text.append(buf, std::size_t(n));
    return text;
}

}  // namespace

TEST(ProgressBar, DrawsOnATerminalAtMostEvery100MsAndEndsTheLineForLongWork) {
    int master = -1, slave = -1;
    ASSERT_EQ(::openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
    {
        const StderrTo redirect(slave);
        glint::ProgressBar bar("test work", 4);
        bar.advance(1);  // within 100 ms of the start: not drawn
        std::this_thread::sleep_for(std::chrono::milliseconds(120));
        bar.advance(1);  // drawn: 2 of 4
        bar.advance(1);  // within 100 ms of that draw: not drawn
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
        bar.finish();  // over 300 ms of work: a final line at 3 of 4
    }
    const std::string shown = drain(master);
    ::close(master);
    ::close(slave);
    // Two draws: 50 % (the second advance), then the final line at 75 % ending in a newline.
    const auto first = shown.find("\rtest work");
    ASSERT_NE(first, std::string::npos) << shown;
    EXPECT_NE(shown.find("[###############...............]  50%"), std::string::npos) << shown;
    EXPECT_NE(shown.find("[######################........]  75%"), std::string::npos) << shown;
    EXPECT_EQ(shown.find(" 25%"), std::string::npos) << "drawn within 100 ms of the start: " << shown;
    const auto second = shown.find("\rtest work", first + 1);
    ASSERT_NE(second, std::string::npos) << "one draw only: " << shown;
    EXPECT_EQ(shown.find("\rtest work", second + 1), std::string::npos) << "more than two draws: " << shown;
    EXPECT_EQ(shown.back(), '\n') << shown;
}

TEST(ProgressBar, WritesNothingWhenStderrIsNotATerminal) {
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    {
        const StderrTo redirect(fds[1]);
        glint::ProgressBar bar("piped work", 2);
        std::this_thread::sleep_for(std::chrono::milliseconds(120));
        bar.advance(2);
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
        bar.finish();
    }
    ::close(fds[1]);
    EXPECT_EQ(drain(fds[0]), "");
    ::close(fds[0]);
}

TEST(KeepFreedMemory, LargeBuffersComeFromTheHeapNotFromMmap) {
    glint::keep_freed_memory();
    // 24 MiB: above glibc's default mmap threshold (128 KiB, raised dynamically only by frees of
    // mmapped blocks) and below the 32 MiB the call sets, so it must come from the heap.
    const std::size_t bytes = std::size_t(24) << 20;
    const std::size_t mmapped_before = mallinfo2().hblkhd;
    void* block = std::malloc(bytes);
    ASSERT_NE(block, nullptr);
    static_cast<volatile char*>(block)[0] = 1;
    const std::size_t mmapped_after = mallinfo2().hblkhd;
    std::free(block);
    EXPECT_EQ(mmapped_after, mmapped_before) << "the 24 MiB block was mmapped";
    // Freed, it stays in the process (the trim threshold is 1 GiB): a second one reuses it.
    const std::size_t arena_before = mallinfo2().arena;
    void* again = std::malloc(bytes);
    EXPECT_EQ(mallinfo2().arena, arena_before) << "the heap grew again for a block it had freed";
    std::free(again);
}

// The kernel's transparent huge page mode, as /sys shows it ("always", "madvise", "never"), or ""
// when the kernel has none.
static std::string transparent_huge_page_mode() {
    std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string line;
    std::getline(in, line);
    const std::size_t open = line.find('['), close = line.find(']');
    return open == std::string::npos || close == std::string::npos ? "" : line.substr(open + 1, close - open - 1);
}

// The THPeligible field of the mapping in /proc/self/smaps that holds `address`, or -1.
static int huge_page_eligible(std::uintptr_t address) {
    std::ifstream in("/proc/self/smaps");
    std::string line;
    bool inside = false;
    while (std::getline(in, line)) {
        std::uintptr_t begin = 0, end = 0;
        char dash = 0;
        std::istringstream head(line);
        if (head >> std::hex >> begin >> dash >> end && dash == '-' && line.find(':') > line.find(' ')) {
            inside = begin <= address && address < end;
            continue;
        }
        if (inside && line.rfind("THPeligible:", 0) == 0) return std::stoi(line.substr(12));
    }
    return -1;
}

// buffer.hpp's allocator advises huge pages for a large buffer (a 100 MB map is then 50 faults,
// not 25,000), whole 2 MiB pages inside the block only.
TEST(UninitVector, LargeBuffersAreAdvisedHugePages) {
    // Which pages are advised: whole 2 MiB pages inside the block, none for a small block.
    const std::uintptr_t huge = std::uintptr_t(2) << 20;
    const auto at = [](std::uintptr_t a) { return reinterpret_cast<const void*>(a); };
    const glint::HugePageSpan odd = glint::huge_page_span(at(5 * huge + 4096), 3 * huge);
    EXPECT_EQ(odd.begin, 6 * huge);
    EXPECT_EQ(odd.end, 8 * huge);
    const glint::HugePageSpan small = glint::huge_page_span(at(4 * huge), huge + huge / 2);
    EXPECT_EQ(small.begin, small.end);
    // And the kernel's view of a 16 MiB buffer: eligible where THP is on (madvise or always; in
    // madvise mode only because of the advice: a plain vector is not), not where it is off.
    const std::string mode = transparent_huge_page_mode();
    glint::UninitVector<float> big;
    big.resize(std::size_t(4) << 20);
    const auto begin = reinterpret_cast<std::uintptr_t>(big.data());
    const std::uintptr_t inside = (begin + huge - 1) / huge * huge + huge;  // a whole huge page in it
    const bool thp_on = mode == "madvise" || mode == "always";
    std::printf("[  report  ] transparent huge pages '%s'\n", mode.c_str());
    if (thp_on) EXPECT_EQ(huge_page_eligible(inside), 1) << "mode " << mode;
    else EXPECT_LE(huge_page_eligible(inside), 0) << "mode " << mode;  // -1: no THP field at all
}

// The allocator's own figures (core/memory.hpp, heap_usage): this test program runs on glibc (on
// the sanitizer's allocator in an AddressSanitizer build), and an 8 MiB block in use shows in
// what it reports, what it holds covering what is in use.
#if defined(__SANITIZE_ADDRESS__)
constexpr const char* kTestAllocator = "asan";
#else
constexpr const char* kTestAllocator = "glibc";
#endif
TEST(HeapUsage, ReportsTheAllocatorAndABlockInUse) {
    EXPECT_STREQ(glint::allocator_name(), kTestAllocator);
    const glint::HeapUsage before = glint::heap_usage();
    ASSERT_GE(before.in_use_bytes, 0);
    EXPECT_GE(before.held_bytes, before.in_use_bytes);
    const std::size_t bytes = std::size_t(8) << 20;
    char* block = static_cast<char*>(std::malloc(bytes));
    ASSERT_NE(block, nullptr);
    static_cast<volatile char*>(block)[bytes - 1] = 1;
    const glint::HeapUsage during = glint::heap_usage();
    std::free(block);
    EXPECT_GE(during.in_use_bytes - before.in_use_bytes, static_cast<long long>(bytes));
    EXPECT_GE(during.held_bytes, during.in_use_bytes);
}
