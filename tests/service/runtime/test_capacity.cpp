// The daemon's memory account and its pool for requests that compute (server_capacity.hpp): what
// is granted, refused, waited for and given back, with threads the way jobs and descriptions use
// them.
#include "runtime/server_capacity.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <future>
#include <mutex>
#include <thread>

#include "error_kind.hpp"
#include "rv/field/error.hpp"

namespace rv::daemon {
namespace {

using namespace std::chrono_literals;

using test::kind_of;

TEST(MemoryAccount, GrantsWithinTheTotalAndTakesBackOnRelease) {
  MemoryAccount a(1000);
  MemoryAccount::Reservation r = a.open();
  r.need(400, false, nullptr, "x");
  EXPECT_GE(r.held(), 400);
  EXPECT_LE(r.held(), 500);  // a quarter more, at most
  EXPECT_EQ(a.reserved(), r.held());
  const int64_t held = r.held();
  r.need(300, false, nullptr, "x");  // below what it holds: nothing asked
  EXPECT_EQ(r.held(), held);
  {
    MemoryAccount::Reservation other = a.open();
    other.need(1000 - held, false, nullptr, "y");
    EXPECT_EQ(a.reserved(), 1000);
    // Nothing left: refused at once without waiting, as a description is.
    EXPECT_EQ(kind_of([&] { r.need(held + 1, false, nullptr, "x"); }), ErrorKind::busy);
    EXPECT_EQ(r.held(), held);
  }
  EXPECT_EQ(a.reserved(), held);
  r.release();
  EXPECT_EQ(a.reserved(), 0);
  // More than the whole account can never be had.
  EXPECT_EQ(kind_of([&] { r.need(1001, true, nullptr, "x"); }), ErrorKind::too_large);
}

TEST(MemoryAccount, MovedReservationsReturnTheirBytesOnce) {
  MemoryAccount a(100);
  {
    MemoryAccount::Reservation r = a.open();
    r.need(50, false, nullptr, "x");
    MemoryAccount::Reservation s = std::move(r);
    EXPECT_EQ(a.reserved(), s.held());
    MemoryAccount::Reservation t = a.open();
    t = std::move(s);
    EXPECT_EQ(a.reserved(), t.held());
  }
  EXPECT_EQ(a.reserved(), 0);
}

TEST(MemoryAccount, AWaiterIsGrantedWhenOtherWorkGivesBack) {
  MemoryAccount a(1000);
  MemoryAccount::Reservation first = a.open();
  first.need(800, false, nullptr, "first");
  auto second = std::async(std::launch::async, [&] {
    MemoryAccount::Reservation r = a.open();
    r.need(600, true, nullptr, "second");
    return r.held();
  });
  // It waits while the first holds its bytes.
  EXPECT_EQ(second.wait_for(300ms), std::future_status::timeout);
  EXPECT_EQ(a.waiting(), 1);
  first.release();
  EXPECT_GE(second.get(), 600);
  EXPECT_EQ(a.reserved(), 0);
  EXPECT_EQ(a.waiting(), 0);
}

TEST(MemoryAccount, ACancelledWaitEnds) {
  MemoryAccount a(100);
  MemoryAccount::Reservation held = a.open();
  held.need(100, false, nullptr, "held");
  std::atomic<bool> cancel{false};
  auto waiter = std::async(std::launch::async, [&] {
    MemoryAccount::Reservation r = a.open();
    return kind_of([&] { r.need(50, true, &cancel, "job"); });
  });
  EXPECT_EQ(waiter.wait_for(200ms), std::future_status::timeout);
  cancel = true;
  EXPECT_EQ(waiter.get(), ErrorKind::cancelled);
  EXPECT_EQ(a.reserved(), 100);
}

// Two jobs each holding part of the account and each waiting for more than is left: neither
// would ever give back. The younger waiter gives way (busy), and the older one goes on.
TEST(MemoryAccount, WhenEveryHolderWaitsTheYoungestGivesWay) {
  MemoryAccount a(1000);
  MemoryAccount::Reservation older = a.open(), younger = a.open();
  older.need(400, false, nullptr, "older");
  younger.need(400, false, nullptr, "younger");
  auto first = std::async(std::launch::async, [&] {
    older.need(700, true, nullptr, "older");
    return older.held();
  });
  std::this_thread::sleep_for(200ms);  // the older one waits first
  auto second = std::async(std::launch::async, [&] {
    const ErrorKind k = kind_of([&] { younger.need(700, true, nullptr, "younger"); });
    younger.release();  // as a job gives back when it fails
    return k;
  });
  EXPECT_EQ(second.get(), ErrorKind::busy);
  EXPECT_GE(first.get(), 700);
}

TEST(RequestPool, RunsUpToItsWorkersAndRefusesTheNext) {
  RequestPool pool(2);
  EXPECT_EQ(pool.workers(), 2);
  std::mutex m;
  std::condition_variable cv;
  bool go = false;
  std::atomic<int> done{0};
  auto task = [&]() -> std::function<void()> {
    std::unique_lock lock(m);
    cv.wait(lock, [&] { return go; });
    ++done;
    return {};
  };
  pool.try_run(task);
  pool.try_run(task);
  EXPECT_EQ(pool.busy(), 2);
  EXPECT_EQ(kind_of([&] { pool.try_run(task); }), ErrorKind::busy);
  {
    std::lock_guard lock(m);
    go = true;
  }
  cv.notify_all();
  for (int i = 0; i < 200 && pool.busy() > 0; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(done.load(), 2);
  EXPECT_EQ(pool.busy(), 0);
  pool.try_run([&]() -> std::function<void()> {  // room again
    ++done;
    return {};
  });
  pool.stop();  // lets it finish
  EXPECT_EQ(done.load(), 3);
  EXPECT_EQ(kind_of([&] { pool.try_run([] { return std::function<void()>{}; }); }), ErrorKind::busy);
}

// A worker counts as idle before its answer is handed over: a client that sends its next request
// on the answer is not refused as busy (a one-worker pool, the next request sent from within the
// hand-over). Before, the worker stayed busy until its whole task returned, and on a loaded
// machine a client's quick succession of requests met 503.
TEST(RequestPool, AWorkerIsIdleBeforeItsAnswerIsHandedOver) {
  RequestPool pool(1);
  std::promise<int> busy_then;
  std::promise<bool> next_taken;
  std::atomic<int> ran{0};
  pool.try_run([&]() -> std::function<void()> {
    return [&] {
      busy_then.set_value(pool.busy());
      try {
        pool.try_run([&] {
          ++ran;
          return std::function<void()>{};
        });
        next_taken.set_value(true);
      } catch (const Error&) {
        next_taken.set_value(false);
      }
    };
  });
  EXPECT_EQ(busy_then.get_future().get(), 0);
  EXPECT_TRUE(next_taken.get_future().get());
  pool.stop();  // lets the next one run
  EXPECT_EQ(ran.load(), 1);
}

}  // namespace
}  // namespace rv::daemon
