// The streaming path's hand-off of strip buffers between the computing thread and one writer
// thread per file (service/src/stream/strip_handoff.hpp), driven directly: every writer sees every
// strip in fill order, a buffer comes back to the computing side only when every writer is done
// with it, and a writer's failure or the computing side's stop ends the stream without a hang
// (a hang fails the test by CTest's timeout); the files are reported in the writers' order.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "stream/strip_handoff.hpp"

namespace rv::detail {
namespace {

constexpr int kBuffers = 2;

// What a writer saw: the strip numbers it read out of the buffers, in the order it took them.
struct Seen {
  std::vector<int> strips;
};

// The computing side: fills `strips` strips into kBuffers buffers (each buffer holds the number
// of the strip in it), checks that no buffer it gets back is still wanted by a writer, then
// closes. Returns the number of strips it filled before the hand-off refused a buffer.
int produce(StripHandoff& h, std::array<std::atomic<int>, kBuffers>& buffer,
            std::array<std::atomic<int>, kBuffers>& readers_left, int strips, int writers) {
  double waited = 0.0;
  for (int s = 0; s < strips; ++s) {
    const std::optional<int> k = h.take_free(waited);
    if (!k) return s;
    // Every writer has given this buffer back: none may still be reading it.
    EXPECT_EQ(readers_left[static_cast<size_t>(*k)].load(), 0) << "strip " << s;
    buffer[static_cast<size_t>(*k)] = s;
    readers_left[static_cast<size_t>(*k)] = writers;
    h.put_filled(*k);
  }
  h.close();
  return strips;
}

// A writer: takes every strip in turn; `fail_at` >= 0 makes it fail on that strip.
void consume(StripHandoff& h, std::array<std::atomic<int>, kBuffers>& buffer,
             std::array<std::atomic<int>, kBuffers>& readers_left, Seen& seen, int fail_at) {
  double waited = 0.0;
  try {
    for (size_t seq = 0;; ++seq) {
      const std::optional<int> k = h.take_filled(seq, waited);
      if (!k) return;
      const int strip = buffer[static_cast<size_t>(*k)].load();
      if (strip == fail_at) throw std::runtime_error("cannot write strip " + std::to_string(strip));
      seen.strips.push_back(strip);
      std::this_thread::yield();  // let the others overtake, or fall behind
      --readers_left[static_cast<size_t>(*k)];
      h.put_done(*k, 10);
    }
  } catch (...) {
    h.fail(std::current_exception());
  }
}

// A hand-off with its buffers free, what the buffers hold, and per writer what it saw.
struct Rig {
  explicit Rig(int writers) : h(writers), seen(static_cast<size_t>(writers)) {
    for (int k = 0; k < kBuffers; ++k) h.add_free(k);
  }
  // A test that ends early (a failed ASSERT) still leaves no thread running.
  ~Rig() {
    h.stop();
    join();
  }
  // Writer i's thread: consume() (failing at `fail_at` if >= 0), then `then` (finished(), a
  // failure of its own, or nothing).
  template <class Then>
  void start(int i, int fail_at, Then then) {
    threads.emplace_back([this, i, fail_at, then] {
      consume(h, buffer, readers_left, seen[static_cast<size_t>(i)], fail_at);
      then(h, i);
    });
  }
  int produce(int strips) {
    return rv::detail::produce(h, buffer, readers_left, strips, static_cast<int>(seen.size()));
  }
  void join() {
    for (std::thread& t : threads)
      if (t.joinable()) t.join();
  }
  StripHandoff h;
  std::array<std::atomic<int>, kBuffers> buffer{}, readers_left{};
  std::vector<Seen> seen;
  std::vector<std::thread> threads;
};

const auto kFinish = [](StripHandoff& h, int i) { h.finished(i); };
const auto kNothing = [](StripHandoff&, int) {};

TEST(StripHandoff, EveryWriterSeesEveryStripInOrderAndBuffersComeBackOnlyWhenAllAreDone) {
  for (const int writers : {1, 2, 3}) {
    SCOPED_TRACE("writers " + std::to_string(writers));
    constexpr int kStrips = 200;
    Rig rig(writers);
    for (int i = 0; i < writers; ++i) rig.start(i, -1, kFinish);
    EXPECT_EQ(rig.produce(kStrips), kStrips);
    std::vector<int64_t> rows;
    rig.h.wait_finished([&](int64_t r) { rows.push_back(r); });
    rig.join();
    for (const Seen& s : rig.seen) {
      ASSERT_EQ(s.strips.size(), static_cast<size_t>(kStrips));
      for (int i = 0; i < kStrips; ++i) EXPECT_EQ(s.strips[static_cast<size_t>(i)], i);
    }
    // Rows count when every writer has a strip: they only grow, and end at all of them.
    ASSERT_FALSE(rows.empty());
    for (size_t i = 1; i < rows.size(); ++i) EXPECT_GT(rows[i], rows[i - 1]);
    EXPECT_EQ(rows.back(), int64_t{10} * kStrips);
    EXPECT_EQ(rig.h.error(), nullptr);
  }
}

TEST(StripHandoff, FilesAreReportedInTheWritersOrder) {
  // Writer 0 finishes first, then writer 1: files 1, then 2. Writer 0 last: its report is the
  // first, and counts both (a file's report follows those before it).
  for (const int late : {1, 0}) {
    SCOPED_TRACE("late writer " + std::to_string(late));
    Rig rig(2);
    std::atomic<bool> first_done{false};
    for (int i = 0; i < 2; ++i)
      rig.start(i, -1, [&, late](StripHandoff& h, int w) {
        if (w == late) std::this_thread::sleep_for(std::chrono::milliseconds(100));
        if (w == 0) first_done = true;
        h.finished(w);
      });
    EXPECT_EQ(rig.produce(20), 20);
    std::vector<int> files;
    bool first_in_place = true;
    rig.h.wait_finished([](int64_t) {},
                        [&](int n) {
                          files.push_back(n);
                          first_in_place = first_in_place && first_done;
                        });
    rig.join();
    EXPECT_EQ(files, late == 1 ? std::vector<int>({1, 2}) : std::vector<int>({2}));
    EXPECT_TRUE(first_in_place);
  }
}

TEST(StripHandoff, AWriterFailingMidStreamStopsTheComputingSideWithItsError) {
  constexpr int kStrips = 50, kFailAt = 7;
  Rig rig(3);
  for (int i = 0; i < 3; ++i) rig.start(i, i == 1 ? kFailAt : -1, kNothing);
  // The failing writer never gives strip kFailAt back, so at most kBuffers more are filled.
  const int filled = rig.produce(kStrips);
  EXPECT_GE(filled, kFailAt + 1);
  EXPECT_LE(filled, kFailAt + kBuffers);
  ASSERT_NE(rig.h.error(), nullptr);
  try {
    std::rethrow_exception(rig.h.error());
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "cannot write strip " + std::to_string(kFailAt));
  }
  // What the job does next: stop the writers still waiting for strips, join them.
  rig.h.stop();
  rig.join();
  EXPECT_EQ(rig.seen[1].strips.size(), static_cast<size_t>(kFailAt));
  for (const Seen& s : rig.seen) EXPECT_LE(s.strips.size(), static_cast<size_t>(filled));
}

TEST(StripHandoff, WaitFinishedRethrowsAnErrorAfterTheLastStrip) {
  // Every strip written, then one writer fails while finishing its file (a rename, say): the
  // computing side, already waiting, gets that error, not a hang.
  Rig rig(2);
  rig.start(0, -1, kFinish);
  rig.start(1, -1, [](StripHandoff& h, int) { h.fail(std::make_exception_ptr(std::runtime_error("rename failed"))); });
  EXPECT_EQ(rig.produce(20), 20);
  EXPECT_THROW(rig.h.wait_finished([](int64_t) {}), std::runtime_error);
  rig.join();
  for (const Seen& s : rig.seen) EXPECT_EQ(s.strips.size(), 20u);
}

TEST(StripHandoff, FilesGoIntoPlaceOnlyOnceEveryFileIsWritten) {
  // Two writers have every row; the third fails writing its last tile: neither of the two may
  // put its file into place. Then, every writer done: all three may.
  {
    StripHandoff h(3);
    std::vector<std::optional<bool>> may(2);
    std::vector<std::thread> t;
    for (int i = 0; i < 2; ++i) t.emplace_back([&h, &may, i] { may[static_cast<size_t>(i)] = h.all_written(); });
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_FALSE(may[0].has_value());  // still waiting for the third
    h.fail(std::make_exception_ptr(std::runtime_error("a copied tile was modified")));
    for (std::thread& x : t) x.join();
    EXPECT_EQ(may[0], std::optional<bool>(false));
    EXPECT_EQ(may[1], std::optional<bool>(false));
  }
  {
    StripHandoff h(3);
    std::vector<std::optional<bool>> may(3);
    std::vector<std::thread> t;
    for (int i = 0; i < 3; ++i) t.emplace_back([&h, &may, i] { may[static_cast<size_t>(i)] = h.all_written(); });
    for (std::thread& x : t) x.join();
    for (const auto& m : may) EXPECT_EQ(m, std::optional<bool>(true));
  }
  {
    StripHandoff h(2);  // the computing side failed: the writer that has every row is released
    std::optional<bool> may;
    std::thread t([&] { may = h.all_written(); });
    h.stop();
    t.join();
    EXPECT_EQ(may, std::optional<bool>(false));
  }
}

TEST(StripHandoff, StopReleasesWritersWaitingForStrips) {
  Rig rig(2);
  for (int i = 0; i < 2; ++i) rig.start(i, -1, kNothing);
  double waited = 0.0;
  const std::optional<int> k = rig.h.take_free(waited);
  ASSERT_TRUE(k);
  rig.buffer[static_cast<size_t>(*k)] = 0;
  rig.readers_left[static_cast<size_t>(*k)] = 2;
  rig.h.put_filled(*k);
  rig.h.stop();  // the computing side failed after one strip: the writers wait for a second
  rig.join();
  for (const Seen& s : rig.seen) EXPECT_LE(s.strips.size(), 1u);
  EXPECT_EQ(rig.h.error(), nullptr);
}

}  // namespace
}  // namespace rv::detail
