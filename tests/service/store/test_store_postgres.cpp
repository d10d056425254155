// The shared job store and queue against a real PostgreSQL 15, started by the test: migrations
// under their lock, records as the SQLite store keeps them, claims that never hand one attempt to
// two workers, leases, fencing, the reaper, dismissal, admission under the principal's lock,
// notifications, retention, and the server going away.
#include <gtest/gtest.h>

#include <atomic>
#include <map>
#include <set>
#include <thread>

#include "postgres_server.hpp"
#include "rv/field/error.hpp"
#include "store/job_columns.hpp"
#include "store/pg_client.hpp"
#include "store/store_postgres.hpp"

namespace {

using rv::Error;
using rv::ErrorKind;
using rv::JobRecord;
using rv::JobStatus;
using rv::store::PostgresJobStore;
using rv::store::QueueEntry;

rv::test::PostgresServer& server() {
  static rv::test::PostgresServer s;
  return s;
}

rv::pg::ConnectInfo info(const std::string& db) {
  return rv::pg::ConnectInfo{server().uri(db), rv::test::PostgresServer::kPassword, "rv-test", 5};
}

JobRecord record(const std::string& id, const std::string& principal = "alice", int64_t cells = 0) {
  JobRecord r;
  r.id = id;
  r.process_id = "voronoi";
  r.message = "queued";
  r.created = r.updated = "2026-11-30T12:00:00.000Z";
  r.inputs = {{"resolution", 0.5}, {"note", "ø and \"quotes\""}};
  r.outputs = {"ownership", "distance"};
  r.transmission = {"reference", "reference"};
  r.formats = {"image/tiff", "image/tiff"};
  r.principal = principal;
  r.cells = cells;
  return r;
}

std::function<std::string(const JobRecord&)> msg(const std::string& text) {
  return [text](const JobRecord&) { return text; };
}

std::string id_of(int i) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%032x", i);
  return buf;
}

// A band of a split job: its id and rows, the rest as a new band's.
rv::store::BandTask band(const std::string& id, int64_t row0, int64_t rows) {
  rv::store::BandTask b;
  b.id = id;
  b.row0 = row0;
  b.rows = rows;
  return b;
}

class PostgresStore : public ::testing::Test {
 protected:
  void SetUp() override { db_ = server().create_database(); }
  std::unique_ptr<PostgresJobStore> open(int pool = 4) { return std::make_unique<PostgresJobStore>(info(db_), pool); }
  std::string db_;
};

TEST_F(PostgresStore, MigrationsApplyOnceWhenDaemonsStartTogether) {
  std::vector<std::thread> threads;
  std::vector<int> before(6, -1);
  std::atomic<int> failures{0};
  for (int i = 0; i < 6; ++i)
    threads.emplace_back([&, i] {
      try {
        before[static_cast<size_t>(i)] = PostgresJobStore(info(db_), 1).schema_version_before();
      } catch (...) {
        ++failures;
      }
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(failures, 0);
  // Exactly one found the empty database; the others found it migrated.
  EXPECT_EQ(std::count(before.begin(), before.end(), 0), 1);
  EXPECT_EQ(std::count(before.begin(), before.end(), rv::store::postgres_schema_version()), 5);
  rv::pg::Connection c(info(db_));
  EXPECT_EQ(c.exec("SELECT count(*) FROM rv_schema_migrations").integer(0, 0), rv::store::postgres_schema_version());
  // A database a newer build migrated is refused, not written with an older schema.
  c.exec("INSERT INTO rv_schema_migrations (version) VALUES (999)");
  try {
    PostgresJobStore newer(info(db_), 1);
    FAIL() << "opened a newer schema";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::unsupported);
    EXPECT_NE(std::string(e.what()).find("version 999"), std::string::npos) << e.what();
  }
}

TEST_F(PostgresStore, RecordsReadBackAsTheSqliteStoreKeepsThem) {
  auto store = open();
  JobRecord r = record(id_of(1), "bob", 1234);
  r.report = {{"cells", 1234}, {"owners", {"DK", "SE"}}};
  store->enqueue(r, QueueEntry{});
  const auto got = store->get(r.id);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->status, JobStatus::accepted);
  EXPECT_EQ(rv::store::record_texts(*got), rv::store::record_texts(r));
  EXPECT_FALSE(store->get(id_of(2)));
  const auto many = store->get_many({id_of(1), id_of(2)});
  ASSERT_EQ(many.size(), 1u);
  EXPECT_EQ(many[0].id, id_of(1));

  for (int i = 2; i <= 5; ++i) {
    JobRecord o = record(id_of(i), i % 2 ? "bob" : "carol", i * 100);
    o.created = "2026-11-30T12:00:0" + std::to_string(i) + ".000Z";
    store->enqueue(o, QueueEntry{});
  }
  const auto all = store->list(10, 0);
  ASSERT_EQ(all.size(), 5u);
  EXPECT_EQ(all.front().id, id_of(5));  // newest first
  EXPECT_EQ(store->list(10, 0, {}, "carol").size(), 2u);
  EXPECT_EQ(store->list(2, 1).size(), 2u);
  EXPECT_EQ(store->list(10, 0, {JobStatus::running}).size(), 0u);
  const auto counts = store->count_by_principal();
  ASSERT_EQ(counts.size(), 2u);
  EXPECT_EQ(counts[0], std::make_pair(std::string("bob"), int64_t{3}));
  EXPECT_EQ(store->charges_since("2026-11-30T12:00:03.000Z").size(), 3u);
}

TEST_F(PostgresStore, ConcurrentClaimsTakeEachJobOnce) {
  auto store = open(8);
  constexpr int kJobs = 60;
  for (int i = 0; i < kJobs; ++i) store->enqueue(record(id_of(i)), QueueEntry{});
  std::mutex m;
  std::map<std::string, std::string> taken;  // job -> holder
  std::atomic<int> duplicates{0};
  std::vector<std::thread> workers;
  for (int w = 0; w < 6; ++w)
    workers.emplace_back([&, w] {
      const std::string holder = "daemon-" + std::to_string(w);
      while (auto c = store->claim(holder, 30, "2026-11-30T12:01:00.000Z")) {
        EXPECT_EQ(c->lease.attempt, 1);
        EXPECT_EQ(c->record.status, JobStatus::running);
        std::lock_guard lock(m);
        if (!taken.emplace(c->record.id, holder).second) ++duplicates;
      }
    });
  for (auto& t : workers) t.join();
  EXPECT_EQ(duplicates, 0);
  EXPECT_EQ(taken.size(), static_cast<size_t>(kJobs));
  EXPECT_FALSE(store->claim("late", 30, ""));
}

TEST_F(PostgresStore, ALostLeasePublishesNothingAndCompletionIsWrittenOnce) {
  auto store = open();
  store->enqueue(record(id_of(7)), QueueEntry{});
  auto first = store->claim("a", 0.2, "t1");
  ASSERT_TRUE(first);
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  const auto reaped = store->reap(0, "t2");
  ASSERT_EQ(reaped.size(), 1u);
  EXPECT_TRUE(reaped[0].requeued);
  EXPECT_EQ(store->get(id_of(7))->status, JobStatus::accepted);
  EXPECT_NE(store->get(id_of(7))->message.find("attempt 1"), std::string::npos);

  auto second = store->claim("b", 30, "t3");
  ASSERT_TRUE(second);
  EXPECT_EQ(second->lease.attempt, 2);
  JobRecord done = second->record;
  done.status = JobStatus::successful;
  done.progress = 100;
  done.message = "finished";
  // The first worker wakes up late: every write of its attempt is refused.
  JobRecord stale = first->record;
  stale.progress = 50;
  EXPECT_FALSE(store->write_running(first->lease, stale));
  stale.status = JobStatus::failed;
  EXPECT_FALSE(store->finish(first->lease, stale, "jobs/x/1"));
  EXPECT_TRUE(store->write_running(second->lease, second->record));
  EXPECT_TRUE(store->finish(second->lease, done, "jobs/x/2"));
  EXPECT_FALSE(store->finish(second->lease, done, "jobs/x/2"));  // once
  const auto rec = store->get(id_of(7));
  EXPECT_EQ(rec->status, JobStatus::successful);
  EXPECT_EQ(rec->progress, 100);
  // A finished job is never reaped, however its lease was left (the trap of a worker pruned as
  // dead failing a job that had finished).
  rv::pg::Connection(info(db_)).exec("UPDATE rv_jobs SET lease_until = now() - interval '1 hour'");
  EXPECT_TRUE(store->reap(0, "t4").empty());
  EXPECT_EQ(store->get(id_of(7))->status, JobStatus::successful);
}

TEST_F(PostgresStore, TheReaperBacksOffThenFailsWithAReason) {
  auto store = open();
  QueueEntry twice;
  twice.max_attempts = 2;
  store->enqueue(record(id_of(8)), twice);
  ASSERT_TRUE(store->claim("a", 0.1, "t"));
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  ASSERT_EQ(store->reap(0.5, "t").size(), 1u);
  EXPECT_FALSE(store->claim("b", 0.1, "t")) << "claimed within its backoff";
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  auto again = store->claim("b", 0.1, "t");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->lease.attempt, 2);
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  const auto reaped = store->reap(0.5, "t-end");
  ASSERT_EQ(reaped.size(), 1u);
  EXPECT_FALSE(reaped[0].requeued);
  const auto rec = store->get(id_of(8));
  EXPECT_EQ(rec->status, JobStatus::failed);
  EXPECT_EQ(rec->error_kind, "internal");
  EXPECT_EQ(rec->finished, "t-end");
  EXPECT_NE(rec->message.find("attempted 2 times"), std::string::npos) << rec->message;

  // Work only its daemon could run fails at the first expiry.
  const auto lease = store->insert_running(record(id_of(9)), QueueEntry{"job", "", "", false, 3}, "c", 0.1);
  EXPECT_EQ(lease.attempt, 1);
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  ASSERT_EQ(store->reap(0, "t").size(), 1u);
  EXPECT_EQ(store->get(id_of(9))->status, JobStatus::failed);
  EXPECT_NE(store->get(id_of(9))->message.find("only that daemon"), std::string::npos);
}

TEST_F(PostgresStore, AJobHandedBackRunsAgainWithoutCountingAnAttempt) {
  auto store = open();
  QueueEntry once;
  once.max_attempts = 1;
  store->enqueue(record(id_of(20)), once);
  auto a = store->claim("a", 30, "t");
  ASSERT_TRUE(a);
  EXPECT_FALSE(store->release(rv::store::Lease{id_of(20), 1, "someone else"}, "m", "t"));
  EXPECT_TRUE(store->release(a->lease, "queued again: its daemon shut down", "t2"));
  EXPECT_FALSE(store->release(a->lease, "again", "t3"));  // the lease went with it
  const auto rec = store->get(id_of(20));
  EXPECT_EQ(rec->status, JobStatus::accepted);
  EXPECT_EQ(rec->message, "queued again: its daemon shut down");
  auto b = store->claim("b", 0.1, "t");
  ASSERT_TRUE(b);
  EXPECT_EQ(b->lease.attempt, 2);
  EXPECT_EQ(b->entry.max_attempts, 2);  // the hand-back did not use up its one attempt
  // Work only its daemon could run is not handed back: it fails with its daemon.
  const auto lease = store->insert_running(record(id_of(21)), QueueEntry{"job", "", "", false, 3}, "c", 30);
  EXPECT_FALSE(store->release(lease, "m", "t"));
  EXPECT_EQ(store->get(id_of(21))->status, JobStatus::running);
}

TEST_F(PostgresStore, HeartbeatsKeepALeaseAndDismissalEndsIt) {
  auto store = open();
  store->enqueue(record(id_of(10)), QueueEntry{});
  store->enqueue(record(id_of(11)), QueueEntry{});
  auto a = store->claim("h", 0.3, "t");
  auto b = store->claim("h", 0.3, "t");
  ASSERT_TRUE(a && b);
  for (int i = 0; i < 6; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_EQ(store->heartbeat("h", 0.3, {id_of(10), id_of(11)}).size(), 2u);
    EXPECT_TRUE(store->reap(0, "t").empty());
  }
  const auto d = store->dismiss(id_of(10), msg("dismissed by the client"), "t-d");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->first.status, JobStatus::running);
  EXPECT_EQ(d->second.status, JobStatus::dismissed);
  const auto held = store->heartbeat("h", 0.3, {id_of(10), id_of(11)});
  ASSERT_EQ(held.size(), 1u);
  EXPECT_EQ(held[0].id, id_of(11));
  JobRecord late = a->record;
  late.status = JobStatus::successful;
  EXPECT_FALSE(store->finish(a->lease, late, "r"));
  EXPECT_EQ(store->get(id_of(10))->status, JobStatus::dismissed);
  EXPECT_FALSE(store->dismiss(id_of(99), msg("m"), "t"));
  // A second dismissal changes nothing.
  const auto again = store->dismiss(id_of(10), msg("other"), "t-e");
  EXPECT_EQ(again->second.message, "dismissed by the client");
}

TEST_F(PostgresStore, ADismissalRacingTheReaperAlwaysWins) {
  // The trap of a cancel racing a rescue: whichever commits first, the job ends dismissed, and no
  // claim takes it afterwards.
  auto store = open(8);
  constexpr int kJobs = 40;
  for (int i = 0; i < kJobs; ++i) store->enqueue(record(id_of(100 + i)), QueueEntry{});
  for (int i = 0; i < kJobs; ++i) ASSERT_TRUE(store->claim("dying", 0.05, "t"));
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  std::thread reaper([&] {
    for (int k = 0; k < 20; ++k) store->reap(0, "t");
  });
  std::thread claimer([&] {
    for (int k = 0; k < 200; ++k)
      if (auto c = store->claim("rescuer", 30, "t")) store->dismiss(c->record.id, msg("dismissed"), "t");
  });
  for (int i = 0; i < kJobs; ++i) store->dismiss(id_of(100 + i), msg("dismissed"), "t");
  reaper.join();
  claimer.join();
  for (int i = 0; i < kJobs; ++i) EXPECT_EQ(store->get(id_of(100 + i))->status, JobStatus::dismissed) << i;
  EXPECT_FALSE(store->claim("after", 30, "t"));
  std::vector<std::string> all;
  for (int i = 0; i < kJobs; ++i) all.push_back(id_of(100 + i));
  EXPECT_TRUE(store->heartbeat("dying", 30, all).empty());
}

TEST_F(PostgresStore, AdmissionSeesEveryDaemonsSubmissions) {
  auto store = open(8);
  std::atomic<int> admitted{0}, refused{0};
  std::vector<std::thread> clients;
  for (int i = 0; i < 8; ++i)
    clients.emplace_back([&, i] {
      try {
        store->enqueue(record(id_of(200 + i), "eve", 100), QueueEntry{}, [](const rv::store::AdmissionView& v) {
          if (v.principal_unfinished >= 3) throw Error(ErrorKind::over_quota, "three at most");
        });
        ++admitted;
      } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::over_quota);
        ++refused;
      }
    });
  for (auto& t : clients) t.join();
  EXPECT_EQ(admitted, 3);
  EXPECT_EQ(refused, 5);
  // The hour's charges are the principal's jobs with cells, timed by the database's clock.
  store->enqueue(record(id_of(300), "frank", 500), QueueEntry{});
  auto c = store->claim("h", 30, "t");
  while (c && c->record.principal != "frank") c = store->claim("h", 30, "t");  // eve's come first
  ASSERT_TRUE(c);
  int64_t seen = -1;
  EXPECT_TRUE(store->charge_planned(c->lease, 700, [&](const rv::store::AdmissionView& v) {
    seen = 0;
    for (const auto& [at, cells] : v.charges) seen += cells;
    EXPECT_LE(std::chrono::abs(v.now - std::chrono::system_clock::now()), std::chrono::seconds(30));
  }));
  EXPECT_EQ(seen, 500);  // frank's own charges only
  EXPECT_EQ(store->get(c->record.id)->cells, 700);
  EXPECT_THROW(store->charge_planned(c->lease, 900,
                                     [](const rv::store::AdmissionView&) { throw Error(ErrorKind::over_quota, "no"); }),
               Error);
  EXPECT_EQ(store->get(c->record.id)->cells, 700);
  EXPECT_FALSE(store->charge_planned(rv::store::Lease{c->record.id, 9, "h"}, 1, {}));
  // Charges that are no job (a session's grid) count in the same hour, for every daemon.
  store->charge("frank", 300, {});
  int64_t hour = 0;
  store->charge("frank", 1, [&](const rv::store::AdmissionView& v) {
    for (const auto& [at, cells] : v.charges) hour += cells;
  });
  EXPECT_EQ(hour, 700 + 300);
  EXPECT_THROW(
      store->charge("frank", 5, [](const rv::store::AdmissionView&) { throw Error(ErrorKind::over_quota, "x"); }),
      Error);
  int64_t listed = 0;
  for (const auto& ch : store->charges_since("2000-01-01T00:00:00.000Z"))
    if (ch.principal == "frank") listed += ch.cells;
  EXPECT_EQ(listed, 700 + 300 + 1);  // the refused charge left nothing
}

TEST_F(PostgresStore, QueueingAndDismissalNotifyListeners) {
  auto store = open();
  rv::pg::Connection listener(info(db_));
  listener.exec(std::string("LISTEN ") + PostgresJobStore::kQueuedChannel);
  listener.exec(std::string("LISTEN ") + PostgresJobStore::kDismissedChannel);
  EXPECT_TRUE(listener.wait_notifications(std::chrono::milliseconds(50)).empty());
  store->enqueue(record(id_of(400)), QueueEntry{});
  auto n = listener.wait_notifications(std::chrono::milliseconds(3000));
  ASSERT_EQ(n.size(), 1u);
  EXPECT_EQ(n[0].channel, PostgresJobStore::kQueuedChannel);
  EXPECT_EQ(n[0].payload, id_of(400));
  store->dismiss(id_of(400), msg("m"), "t");
  n = listener.wait_notifications(std::chrono::milliseconds(3000));
  ASSERT_EQ(n.size(), 1u);
  EXPECT_EQ(n[0].channel, PostgresJobStore::kDismissedChannel);
}

TEST_F(PostgresStore, RetentionDeletesFinishedJobsWithTheirTasks) {
  auto store = open();
  store->enqueue(record(id_of(500)), QueueEntry{"job", "", "jobs/500/request.json", true, 3});
  store->enqueue(record(id_of(501)), QueueEntry{"band", id_of(500), "", true, 3});
  store->enqueue(record(id_of(502)), QueueEntry{});
  auto c = store->claim("h", 30, "t");
  ASSERT_TRUE(c);
  ASSERT_EQ(c->record.id, id_of(500));
  JobRecord done = c->record;
  done.status = JobStatus::successful;
  ASSERT_TRUE(store->finish(c->lease, done, "jobs/500/1/"));
  const auto keys = store->referenced_keys();
  EXPECT_EQ(std::set<std::string>(keys.begin(), keys.end()),
            (std::set<std::string>{"jobs/500/request.json", "jobs/500/1/"}));
  EXPECT_TRUE(store->expire(3600, 10).empty());
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const auto gone = store->expire(0.01, 10);
  ASSERT_EQ(gone.size(), 1u);
  EXPECT_EQ(gone[0].id, id_of(500));
  EXPECT_EQ(gone[0].payload, "jobs/500/request.json");
  EXPECT_EQ(gone[0].results, "jobs/500/1/");
  EXPECT_FALSE(store->entry(id_of(501)));  // the task went with its job
  EXPECT_TRUE(store->get(id_of(502)));     // unfinished: kept
}

TEST_F(PostgresStore, ASplitJobWaitsForItsBandsThenIsAssembledOnce) {
  auto store = open();
  using rv::store::BandTask;
  store->enqueue(record(id_of(30), "alice", 900), QueueEntry{});
  auto job = store->claim("a", 30, "t");
  ASSERT_TRUE(job);
  EXPECT_FALSE(job->split);
  const std::vector<BandTask> cut = {band(id_of(31), 0, 512), band(id_of(32), 512, 512), band(id_of(33), 1024, 100)};
  EXPECT_FALSE(store->split(rv::store::Lease{job->lease.id, job->lease.attempt, "b"}, cut, "m", "t"))
      << "split under a lease not held";
  ASSERT_TRUE(store->split(job->lease, cut, "computing in 3 bands", "t"));
  // The job runs on without a lease: heartbeats, reaping and other fenced writes leave it be.
  EXPECT_EQ(store->get(id_of(30))->status, JobStatus::running);
  EXPECT_EQ(store->get(id_of(30))->message, "computing in 3 bands");
  EXPECT_TRUE(store->heartbeat("a", 30, {id_of(30)}).empty());
  JobRecord early = record(id_of(30));
  early.status = JobStatus::successful;
  EXPECT_FALSE(store->finish(job->lease, early, "x")) << "the job's old lease published";
  // Its bands: claimed like jobs, never listed as jobs, their rows in the payload.
  std::vector<rv::store::Claim> bands;
  while (auto b = store->claim("w", 0.2, "t")) bands.push_back(*b);
  ASSERT_EQ(bands.size(), 3u);
  for (const auto& b : bands) {
    EXPECT_EQ(b.entry.kind, "band");
    EXPECT_EQ(b.entry.parent, id_of(30));
    EXPECT_EQ(b.record.principal, "alice");
    EXPECT_FALSE(store->get(b.record.id)) << "a band is no job";
  }
  EXPECT_EQ(store->list(100, 0).size(), 1u);
  // One band's lease expires: queued again (its job waits on).
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(store->reap(0, "t").size(), 3u);
  for (int i = 0; i < 3; ++i) {
    auto b = store->claim("w2", 30, "t");
    ASSERT_TRUE(b);
    JobRecord done = b->record;
    done.status = JobStatus::successful;
    const std::string results = id_of(30) + "/bands/" + b->entry.payload;
    ASSERT_TRUE(store->finish_band(b->lease, id_of(30), done, results, "", "t"));
    EXPECT_FALSE(store->finish_band(b->lease, id_of(30), done, results, "", "t")) << "a band ends once";
    // Until the last band ends, the job is not queued.
    if (i < 2) {
      EXPECT_EQ(store->get(id_of(30))->status, JobStatus::running);
    }
  }
  const auto listed = store->bands(id_of(30));
  ASSERT_EQ(listed.size(), 3u);
  EXPECT_EQ(listed[0].row0, 0);
  EXPECT_EQ(listed[2].rows, 100);
  for (const auto& b : listed) EXPECT_EQ(b.status, JobStatus::successful);
  // Queued again, and claimed to be assembled (attempt 2, not counted against its attempts).
  EXPECT_EQ(store->get(id_of(30))->status, JobStatus::accepted);
  auto assemble = store->claim("c", 30, "t");
  ASSERT_TRUE(assemble);
  EXPECT_EQ(assemble->record.id, id_of(30));
  EXPECT_TRUE(assemble->split);
  EXPECT_EQ(assemble->lease.attempt, 2);
  EXPECT_EQ(assemble->entry.max_attempts, 4);
  JobRecord end = assemble->record;
  end.status = JobStatus::successful;
  EXPECT_TRUE(store->finish(assemble->lease, end, id_of(30) + "/2"));

  // A band that fails fails its job, naming the band, and the other bands go.
  store->enqueue(record(id_of(40)), QueueEntry{});
  auto j2 = store->claim("a", 30, "t");
  ASSERT_TRUE(store->split(j2->lease, {band(id_of(41), 0, 256), band(id_of(42), 256, 256)}, "m", "t"));
  auto b1 = store->claim("w", 30, "t");
  ASSERT_TRUE(b1);
  JobRecord failed = b1->record;
  failed.status = JobStatus::failed;
  failed.error_kind = "too_large";
  failed.message = "out of memory";
  ASSERT_TRUE(
      store->finish_band(b1->lease, id_of(40), failed, "", "the band of rows 0..256 failed: out of memory", "t-f"));
  const auto j2rec = store->get(id_of(40));
  EXPECT_EQ(j2rec->status, JobStatus::failed);
  EXPECT_EQ(j2rec->error_kind, "too_large");
  EXPECT_EQ(j2rec->message, "the band of rows 0..256 failed: out of memory");
  EXPECT_FALSE(store->claim("w", 30, "t")) << "the other band was dismissed";
  // The reaper failing a band fails its job likewise.
  store->enqueue(record(id_of(50)), QueueEntry{"job", "", "", true, 1});
  auto j3 = store->claim("a", 30, "t");
  ASSERT_TRUE(store->split(j3->lease, {band(id_of(51), 0, 256)}, "m", "t"));
  ASSERT_TRUE(store->claim("w", 0.1, "t"));
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  ASSERT_EQ(store->reap(0, "t").size(), 1u);
  EXPECT_EQ(store->get(id_of(50))->status, JobStatus::failed);
  EXPECT_NE(store->get(id_of(50))->message.find("band of rows 0:256 failed"), std::string::npos)
      << store->get(id_of(50))->message;
  // Dismissing a split job dismisses its bands (their holders learn it by their heartbeat).
  store->enqueue(record(id_of(60)), QueueEntry{});
  auto j4 = store->claim("a", 30, "t");
  ASSERT_TRUE(store->split(j4->lease, {band(id_of(61), 0, 256), band(id_of(62), 256, 256)}, "m", "t"));
  auto b4 = store->claim("w", 30, "t");
  ASSERT_TRUE(b4);
  ASSERT_TRUE(store->dismiss(id_of(60), msg("dismissed"), "t"));
  EXPECT_TRUE(store->heartbeat("w", 30, {b4->record.id}).empty());
  EXPECT_FALSE(store->claim("w", 30, "t"));
}

TEST_F(PostgresStore, BandsEndingAtOnceQueueTheirJobOnce) {
  // Each band's end checks whether every other band has ended: without taking them one after the
  // other, the last two ending at once each see the other running, and the job waits for ever.
  auto store = open(10);
  for (int round = 0; round < 5; ++round) {
    const std::string job = id_of(100 + round * 10);
    store->enqueue(record(job), QueueEntry{});
    auto j = store->claim("a", 30, "t");
    ASSERT_TRUE(j);
    std::vector<rv::store::BandTask> cut;
    for (int k = 0; k < 8; ++k) cut.push_back(band(id_of(100 + round * 10 + 1 + k), k * 256, 256));
    ASSERT_TRUE(store->split(j->lease, cut, "m", "t"));
    std::vector<rv::store::Claim> bands;
    while (auto b = store->claim("w", 30, "t")) bands.push_back(*b);
    ASSERT_EQ(bands.size(), 8u);
    std::vector<std::thread> threads;
    for (const auto& b : bands)
      threads.emplace_back([&store, b, job] {
        JobRecord done = b.record;
        done.status = JobStatus::successful;
        EXPECT_TRUE(store->finish_band(b.lease, job, done, job + "/bands/" + b.entry.payload, "", "t"));
      });
    for (std::thread& t : threads) t.join();
    EXPECT_EQ(store->get(job)->status, JobStatus::accepted) << "round " << round;
    auto assemble = store->claim("c", 30, "t");
    ASSERT_TRUE(assemble);
    EXPECT_EQ(assemble->record.id, job);
    EXPECT_TRUE(assemble->split);
    EXPECT_FALSE(store->claim("c", 30, "t")) << "queued twice";
  }
}

TEST_F(PostgresStore, AnUnreachableServerIsUnavailableAndNeverShowsThePassword) {
  rv::pg::ConnectInfo closed{"postgresql://rv@127.0.0.1:1/postgres", "s3cret-pw", "rv-test", 2};
  try {
    PostgresJobStore store(closed, 1);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::busy);
    EXPECT_NE(std::string(e.what()).find("the job store is unavailable"), std::string::npos) << e.what();
  }
  rv::pg::ConnectInfo wrong = info(db_);
  wrong.password = "not-the-password-xyz";
  try {
    rv::pg::Connection c(wrong);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::busy);
    EXPECT_NE(std::string(e.what()).find("password authentication failed"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("not-the-password"), std::string::npos) << e.what();
  }
}

TEST_F(PostgresStore, TheStoreOutlivesAServerRestart) {
  auto store = open(2);
  store->enqueue(record(id_of(600)), QueueEntry{});
  server().stop();
  try {
    store->get(id_of(600));
    FAIL() << "read from a stopped server";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::busy) << e.what();
  }
  server().start();
  // The pooled connections died with the server: the pool notices and connects again.
  const auto rec = store->get(id_of(600));
  ASSERT_TRUE(rec);
  EXPECT_EQ(rec->status, JobStatus::accepted);
}

}  // namespace
