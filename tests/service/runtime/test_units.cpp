// Unit tests of the daemon's parts that need no network: configuration, job store, helpers and
// the translation of execute requests.
#include <cpl_vsi.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "daemon/server_api.hpp"
#include "daemon/server_execute.hpp"
#include "daemon/server_web.hpp"
#include "error_kind.hpp"
#include "runtime/server_connections.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/json_text.hpp"
#include "rv/server_config.hpp"
#include "rv/store_jobs.hpp"

namespace {

using nlohmann::json;
using rv::ErrorKind;

using rv::test::kind_of;

template <class F>
std::string message_of(F&& f) {
  try {
    f();
  } catch (const rv::Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no rv::Error thrown";
  return {};
}

std::filesystem::path temp_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("rv_service_units_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(Config, DefaultsWorkAndKeysAreParsed) {
  const rv::ServerConfig d = rv::parse_server_config(json::object());
  EXPECT_EQ(d.host, "127.0.0.1");
  EXPECT_EQ(d.port, 8080);
  EXPECT_EQ(d.data_dir, "./rvoronoi-data");
  const rv::ServerConfig c = rv::parse_server_config(json::parse(R"({
    "listen": "0.0.0.0:0", "data_dir": "/tmp/x", "public_url": "https://v.example.org/",
    "http": {"max_body_bytes": 2048, "max_header_bytes": 1024, "request_timeout_s": 2.5, "io_threads": 1},
    "jobs": {"workers": 3, "queue_length": 0, "threads_per_job": 2, "job_timeout_s": 60, "shutdown_grace_s": 1},
    "limits": {"max_cells": 1000, "max_memory_bytes": 1048576, "validate_max_cells": 10}})"));
  EXPECT_EQ(c.host, "0.0.0.0");
  EXPECT_EQ(c.port, 0);
  EXPECT_EQ(c.public_url, "https://v.example.org");
  EXPECT_EQ(c.http.max_body_bytes, 2048);
  EXPECT_EQ(c.http.max_header_bytes, 1024);
  EXPECT_DOUBLE_EQ(c.http.request_timeout_s, 2.5);
  EXPECT_EQ(c.jobs.workers, 3);
  EXPECT_EQ(c.jobs.queue_length, 0);
  EXPECT_EQ(c.limits.max_cells, 1000);
  EXPECT_EQ(rv::effective_limits(c).max_memory_bytes, 1048576);
  EXPECT_GT(rv::effective_limits(d).max_memory_bytes, 0);  // resolved from physical memory
}

TEST(Config, AStoreIsSqliteOrAPostgresUriWithItsPasswordApart) {
  const rv::ServerConfig d = rv::parse_server_config(nlohmann::json::object());
  EXPECT_FALSE(d.store.shared());
  auto refused = [](const nlohmann::json& doc, const std::string& key) {
    try {
      rv::parse_server_config(doc);
      ADD_FAILURE() << doc.dump() << " was accepted";
    } catch (const rv::Error& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find("hunter2"), std::string::npos) << e.what();  // never echoed
    }
  };
  const std::string uri = "postgresql://rv@db.example.org:5432/rvoronoi";
  refused({{"store", "mysql://x"}}, "store");
  refused({{"store", "postgresql://rv:hunter2@db/rv"}, {"results", "/srv"}, {"results_shared", true}}, "password");
  refused({{"store", uri + "?password=hunter2"}, {"results", "/srv"}, {"results_shared", true}}, "password");
  // Several daemons need one results location, and a local folder must be said to be shared.
  refused({{"store", uri}}, "results");
  refused({{"store", uri}, {"results", "/srv/rv"}}, "results_shared");
  refused({{"store", uri}, {"results", "/srv/rv"}, {"results_shared", "yes"}}, "results_shared");
  refused(
      {{"store", uri}, {"results", "/srv/rv"}, {"results_shared", true}, {"store_password_file", "/nonexistent/pw"}},
      "store_password_file");
  refused({{"jobs", {{"lease_s", 0}}}}, "jobs.lease_s");
  refused({{"jobs", {{"max_attempts", 0}}}}, "jobs.max_attempts");

  const auto dir = std::filesystem::temp_directory_path() / ("rv-units-store-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "pw") << "hunter2\n";
  const rv::ServerConfig c =
      rv::parse_server_config({{"store", uri},
                               {"results", "/srv/rv"},
                               {"results_shared", true},
                               {"store_password_file", (dir / "pw").string()},
                               {"store_connections", 4},
                               {"jobs", {{"lease_s", 12}, {"retention_s", 86400}, {"split_cells", 50000000}}}});
  std::filesystem::remove_all(dir);
  EXPECT_TRUE(c.store.shared());
  EXPECT_EQ(c.store.uri, uri);
  EXPECT_EQ(c.store.password, "hunter2");
  EXPECT_EQ(c.store.connections, 4);
  EXPECT_EQ(c.jobs.lease_s, 12);
  EXPECT_EQ(c.jobs.retention_s, 86400);
  EXPECT_EQ(c.jobs.split_cells, 50000000);
  // A bucket is shared by every daemon that names it; the embedded store keeps its own results.
  EXPECT_EQ(rv::parse_server_config({{"store", uri}, {"results", "s3://rv-jobs/prod"}}).store.results,
            "s3://rv-jobs/prod");
  refused({{"results", "/srv/rv"}}, "goes with a postgresql:// store");
  refused({{"jobs", {{"split_cells", -1}}}}, "jobs.split_cells");
  // Or from the environment.
  ::setenv("RVORONOI_STORE_PASSWORD", "from-env", 1);
  const rv::ServerConfig e =
      rv::parse_server_config({{"store", uri}, {"results", "/srv/rv"}, {"results_shared", true}});
  ::unsetenv("RVORONOI_STORE_PASSWORD");
  EXPECT_EQ(e.store.password, "from-env");
}

TEST(Config, TheExampleFileHoldsTheDefaults) {
  const char* src = std::getenv("RV_SOURCE_DIR");
  ASSERT_NE(src, nullptr);
  const rv::ServerConfig e = rv::load_server_config(std::string(src) + "/service/serve-config.example.json");
  const rv::ServerConfig d;
  EXPECT_EQ(e.host, d.host);
  EXPECT_EQ(e.port, d.port);
  EXPECT_EQ(e.data_dir, d.data_dir);
  EXPECT_EQ(e.http.max_body_bytes, d.http.max_body_bytes);
  EXPECT_EQ(e.http.max_header_bytes, d.http.max_header_bytes);
  EXPECT_EQ(e.http.request_timeout_s, d.http.request_timeout_s);
  EXPECT_EQ(e.http.io_threads, d.http.io_threads);
  EXPECT_EQ(e.jobs.workers, d.jobs.workers);
  EXPECT_EQ(e.jobs.queue_length, d.jobs.queue_length);
  EXPECT_EQ(e.jobs.threads_per_job, d.jobs.threads_per_job);
  EXPECT_EQ(e.jobs.job_timeout_s, d.jobs.job_timeout_s);
  EXPECT_EQ(e.jobs.shutdown_grace_s, d.jobs.shutdown_grace_s);
  EXPECT_EQ(e.limits.max_cells, d.limits.max_cells);
  EXPECT_EQ(e.limits.max_memory_bytes, d.limits.max_memory_bytes);
  EXPECT_EQ(e.limits.validate_max_cells, d.limits.validate_max_cells);
  EXPECT_EQ(e.limits.max_features, d.limits.max_features);
  EXPECT_EQ(e.limits.max_vertices, d.limits.max_vertices);
  EXPECT_EQ(e.limits.max_input_bytes, d.limits.max_input_bytes);
  EXPECT_EQ(e.http.max_connections, d.http.max_connections);
  EXPECT_EQ(e.retained_free_bytes, d.retained_free_bytes);
  EXPECT_EQ(e.min_free_disk_bytes, d.min_free_disk_bytes);
  EXPECT_EQ(e.jobs.lease_s, d.jobs.lease_s);
  EXPECT_EQ(e.jobs.max_attempts, d.jobs.max_attempts);
  EXPECT_EQ(e.jobs.retry_backoff_s, d.jobs.retry_backoff_s);
  EXPECT_EQ(e.jobs.poll_s, d.jobs.poll_s);
  EXPECT_EQ(e.jobs.retention_s, d.jobs.retention_s);
  EXPECT_EQ(e.jobs.orphan_grace_s, d.jobs.orphan_grace_s);
  EXPECT_EQ(e.store.uri, d.store.uri);
  EXPECT_EQ(e.store.connections, d.store.connections);
  EXPECT_EQ(e.store.results, d.store.results);
  EXPECT_EQ(e.store.results_shared, d.store.results_shared);
  EXPECT_EQ(e.sessions.max_sessions, d.sessions.max_sessions);
  EXPECT_EQ(e.sessions.max_per_principal, d.sessions.max_per_principal);
  EXPECT_EQ(e.sessions.max_memory_bytes, d.sessions.max_memory_bytes);
  EXPECT_EQ(e.sessions.session_memory_bytes, d.sessions.session_memory_bytes);
  EXPECT_EQ(e.sessions.undo_depth, d.sessions.undo_depth);
  EXPECT_EQ(e.sessions.idle_expiry_s, d.sessions.idle_expiry_s);
  EXPECT_EQ(e.sessions.workers, d.sessions.workers);
  EXPECT_EQ(e.sessions.pending_per_session, d.sessions.pending_per_session);
  EXPECT_EQ(e.daemon_name, d.daemon_name);
}

// The allocator's thresholds: from limits.retained_free_bytes, none when it is 0 or when the
// environment sets a malloc tunable; above an int refused.
TEST(Config, AllocatorSettingsFollowTheKeyUnlessTheEnvironmentSetsThem) {
  rv::ServerConfig c;
  rv::AllocatorSettings s = rv::allocator_settings(c, nullptr);
  EXPECT_TRUE(s.apply);
  EXPECT_EQ(s.trim_threshold, int64_t{1} << 30);
  EXPECT_EQ(s.mmap_threshold, int64_t{32} << 20);
  c = rv::parse_server_config(json::parse(R"({"limits": {"retained_free_bytes": 268435456}})"));
  s = rv::allocator_settings(c, "glibc.pthread.mutex_spin_count=10");
  EXPECT_TRUE(s.apply);
  EXPECT_EQ(s.trim_threshold, 268435456);
  EXPECT_FALSE(rv::allocator_settings(c, "glibc.malloc.arena_max=1").apply);
  c = rv::parse_server_config(json::parse(R"({"limits": {"retained_free_bytes": 0}})"));
  EXPECT_FALSE(rv::allocator_settings(c, nullptr).apply);
  EXPECT_NE(message_of([] {
              rv::parse_server_config(json::parse(R"({"limits": {"retained_free_bytes": 4294967296}})"));
            }).find("limits.retained_free_bytes"),
            std::string::npos);
  EXPECT_NE(message_of([] {
              rv::parse_server_config(json::parse(R"({"limits": {"retained_free_bytes": -1}})"));
            }).find("retained_free_bytes"),
            std::string::npos);
}

// The floor of free disk space: 512 MiB unless set, 0 turns it off, a negative one is refused by name.
TEST(Config, MinFreeDiskBytes) {
  EXPECT_EQ(rv::ServerConfig{}.min_free_disk_bytes, int64_t{512} << 20);
  EXPECT_EQ(rv::parse_server_config(json::parse(R"({"limits": {"min_free_disk_bytes": 0}})")).min_free_disk_bytes, 0);
  EXPECT_EQ(
      rv::parse_server_config(json::parse(R"({"limits": {"min_free_disk_bytes": 1073741824}})")).min_free_disk_bytes,
      int64_t{1} << 30);
  EXPECT_NE(message_of([] {
              rv::parse_server_config(json::parse(R"({"limits": {"min_free_disk_bytes": -1}})"));
            }).find("limits.min_free_disk_bytes"),
            std::string::npos);
}

TEST(Config, SessionKeysAndTheirBudgets) {
  rv::ServerConfig c = rv::parse_server_config(json::parse(
      R"({"limits": {"total_memory_bytes": 1000000}, "daemon_name": "node-7",
          "sessions": {"max_sessions": 3, "max_memory_bytes": 600000, "session_memory_bytes": 900000,
                       "undo_depth": 5, "idle_expiry_s": 0.5, "workers": 1}})"));
  EXPECT_EQ(c.daemon_name, "node-7");
  EXPECT_EQ(c.sessions.max_sessions, 3);
  EXPECT_EQ(c.sessions.undo_depth, 5);
  EXPECT_DOUBLE_EQ(c.sessions.idle_expiry_s, 0.5);
  EXPECT_EQ(rv::sessions_memory_budget(c), 600000);
  EXPECT_EQ(rv::session_memory_limit(c), 600000);  // one session never above all of them
  c = rv::parse_server_config(json::parse(R"({"limits": {"total_memory_bytes": 1000000}})"));
  EXPECT_EQ(rv::sessions_memory_budget(c), 500000);  // half the account by default
  EXPECT_NE(
      message_of([] { rv::parse_server_config(json::parse(R"({"daemon_name": "Node_7"})")); }).find("daemon_name"),
      std::string::npos);
  EXPECT_NE(
      message_of([] { rv::parse_server_config(json::parse(R"({"sessions": {"undo": 5}})")); }).find("sessions.undo"),
      std::string::npos);
  EXPECT_EQ(kind_of([] { rv::parse_server_config(json::parse(R"({"sessions": {"workers": 0}})")); }),
            ErrorKind::invalid_argument);
}

TEST(Config, MistakesAreRefusedNamingTheKey) {
  EXPECT_NE(message_of([] { rv::parse_server_config(json::parse(R"({"jobs": {"worker": 2}})")); }).find("jobs.worker"),
            std::string::npos);
  EXPECT_EQ(kind_of([] { rv::parse_server_config(json::parse(R"({"http": {"max_body_bytes": "big"}})")); }),
            ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([] { rv::parse_server_config(json::parse(R"({"jobs": {"workers": 0}})")); }),
            ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([] { rv::load_server_config("/nonexistent/rv.json"); }), ErrorKind::not_found);
  rv::ServerConfig c;
  rv::parse_listen("[::1]:9000", c);
  EXPECT_EQ(c.host, "::1");
  EXPECT_EQ(c.port, 9000);
  EXPECT_EQ(kind_of([&] { rv::parse_listen("localhost", c); }), ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([&] { rv::parse_listen("a:70000", c); }), ErrorKind::invalid_argument);
}

TEST(Util, JobIdsAre128RandomBitsInHex) {
  std::set<std::string> ids;
  for (int i = 0; i < 1000; ++i) {
    const std::string id = rv::daemon::new_job_id();
    EXPECT_TRUE(rv::daemon::is_job_id(id)) << id;
    ids.insert(id);
  }
  EXPECT_EQ(ids.size(), 1000u);
  for (const char* bad : {"", "../../etc/passwd", "0123456789ABCDEF0123456789abcdef", "0123456789abcdef0123456789abcde",
                          "0123456789abcdef0123456789abcdef0", "0123456789abcdef/123456789abcdef"}) {
    EXPECT_FALSE(rv::daemon::is_job_id(bad)) << bad;
  }
}

TEST(Util, Base64AndTimestamps) {
  EXPECT_EQ(rv::daemon::base64_decode("TWFu", "x"), "Man");
  EXPECT_EQ(rv::daemon::base64_decode("TWE=", "x"), "Ma");
  EXPECT_EQ(rv::daemon::base64_decode("TQ==\n", "x"), "M");
  EXPECT_EQ(rv::daemon::base64_decode("", "x"), "");
  EXPECT_EQ(kind_of([] { rv::daemon::base64_decode("TW*u", "input 'seeds'"); }), ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([] { rv::daemon::base64_decode("T", "x"); }), ErrorKind::invalid_argument);
  const auto t = std::chrono::system_clock::time_point(std::chrono::milliseconds(1'700'000'000'123));
  EXPECT_EQ(rv::daemon::rfc3339(t), "2023-11-14T22:13:20.123Z");
  EXPECT_EQ(rv::daemon::http_date(t), "Tue, 14 Nov 2023 22:13:20 GMT");
}

// A database written before output formats were recorded gains the column on open; its jobs
// read back with no formats (each output's default).
TEST(Store, OpensADatabaseWithoutTheFormatsColumn) {
  const auto dir = temp_dir("store_old");
  const std::string id = rv::daemon::new_job_id();
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir / "jobs.sqlite").c_str(), &db), SQLITE_OK);
    const std::string sql =
        "CREATE TABLE jobs (id TEXT PRIMARY KEY, process_id TEXT NOT NULL, status TEXT NOT NULL,"
        " message TEXT NOT NULL, error_kind TEXT NOT NULL, progress INTEGER NOT NULL,"
        " created TEXT NOT NULL, started TEXT NOT NULL, finished TEXT NOT NULL,"
        " updated TEXT NOT NULL, inputs TEXT NOT NULL, outputs TEXT NOT NULL,"
        " transmission TEXT NOT NULL, report TEXT NOT NULL);"
        "INSERT INTO jobs VALUES ('" +
        id +
        "', 'voronoi', 'successful', 'finished', '', 100,"
        " '2026-01-01T00:00:00.000Z', '', '', '2026-01-01T00:00:00.000Z', '{}', '[\"ownership\"]',"
        " '[\"reference\"]', '')";
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  for (int reopen = 0; reopen < 2; ++reopen) {
    rv::JobStore store(dir / "jobs.sqlite");
    const auto got = store.get(id);
    ASSERT_TRUE(got);
    EXPECT_EQ(got->outputs, (std::vector<std::string>{"ownership"}));
    EXPECT_TRUE(got->formats.empty());
    rv::JobRecord updated = *got;
    updated.formats = {"image/tiff; application=geotiff; profile=cloud-optimized"};
    store.update(updated);
    EXPECT_EQ(store.get(id)->formats, updated.formats);
    updated.formats.clear();
    store.update(updated);
  }
}

// A store written by an older build may hold bytes that are not UTF-8 in any text column (the
// message quoted a damaged upload) and JSON columns that hold them too: the record opens, its
// text is escaped, and everything about it can be written out as JSON again.
TEST(Store, RecordsWithInvalidUtf8OpenEscaped) {
  const auto dir = temp_dir("store_utf8");
  const std::string id = rv::daemon::new_job_id();
  { rv::JobStore create(dir / "jobs.sqlite"); }
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir / "jobs.sqlite").c_str(), &db), SQLITE_OK);
    const std::string sql =
        "INSERT INTO jobs (id, process_id, status, message, error_kind, progress, created, started,"
        " finished, updated, inputs, outputs, transmission, report, formats) VALUES ('" +
        id +
        "', 'voronoi', 'failed', CAST(x'6e65617220225c78383022' || x'80ff' AS TEXT),"
        " 'no-such-kind', 900, '2026-01-01T00:00:00.000Z', '', '', '2026-01-01T00:00:00.000Z',"
        " CAST('{\"ownerField\": \"o' || x'80' || '\"}' AS TEXT), '[\"ownership\", 5]', 'not json',"
        " CAST('{\"owners\": [\"A' || x'80' || '\"]}' AS TEXT), '[]')";
    char* err = nullptr;
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
    sqlite3_close(db);
  }
  rv::JobStore store(dir / "jobs.sqlite");
  const auto got = store.get(id);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->message, "near \"\\\\x80\"\\x80\\xFF");  // typed "\x80" kept apart from the bytes
  EXPECT_TRUE(rv::is_valid_utf8(got->message));
  EXPECT_EQ(got->progress, 100);
  EXPECT_EQ(got->inputs.at("ownerField"), "o\\x80");
  EXPECT_EQ(got->outputs, (std::vector<std::string>{"ownership"}));
  EXPECT_TRUE(got->transmission.empty());
  EXPECT_EQ(got->report.at("owners").at(0), "A\\x80");
  const auto listed = store.list(10, 0);
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].message, got->message);
  rv::JobRecord again = *got;
  store.update(again);  // and it writes back
  EXPECT_EQ(store.get(id)->message, got->message);
}

TEST(JsonText, InvalidUtf8IsWrittenEscapedNeverThrown) {
  json doc = {{"label", std::string("A\x80")}, {"list", {std::string("\xff"), 1}}};
  doc[std::string("k\xc3")] = "v";
  EXPECT_THROW(doc.dump(), json::type_error);  // what used to abort the daemon
  const std::string text = rv::json_text(doc);
  const json back = json::parse(text);
  EXPECT_EQ(back.at("label"), "A\\x80");
  EXPECT_EQ(back.at("list").at(0), "\\xFF");
  EXPECT_EQ(back.at("k\\xC3"), "v");
  // Valid documents are written exactly as dump() writes them.
  const json ok = {{"a", "\xc3\x98"}, {"b", {1, 2}}};
  EXPECT_EQ(rv::json_text(ok, 2), ok.dump(2));
  // Stored JSON text with raw bytes parses, the bytes escaped inside its strings.
  EXPECT_EQ(rv::parse_stored_json(std::string("{\"a\": \"x\x80\"}")).at("a"), "x\\x80");
  EXPECT_TRUE(rv::parse_stored_json("{").is_discarded());
}

TEST(Util, PreferIsReadAsRfc7240Says) {
  using rv::daemon::prefers_respond_async;
  EXPECT_TRUE(prefers_respond_async("respond-async"));
  EXPECT_TRUE(prefers_respond_async("Respond-Async"));
  EXPECT_TRUE(prefers_respond_async("wait=10, RESPOND-ASYNC"));
  EXPECT_TRUE(prefers_respond_async(" respond-async ; x=1"));
  EXPECT_TRUE(prefers_respond_async("return=minimal,respond-async"));
  EXPECT_FALSE(prefers_respond_async(""));
  EXPECT_FALSE(prefers_respond_async("wait=10"));
  EXPECT_FALSE(prefers_respond_async("respond-asynchronously"));
  EXPECT_FALSE(prefers_respond_async("x=respond-async"));
}

TEST(Util, SecretsInQueryStringsAreNotLogged) {
  using rv::daemon::loggable_target;
  EXPECT_EQ(loggable_target("/jobs?limit=2&access_token=abc"), "/jobs?limit=2&access_token=REDACTED");
  EXPECT_EQ(loggable_target("/jobs?API_KEY=x&status=failed"), "/jobs?API_KEY=REDACTED&status=failed");
  EXPECT_EQ(loggable_target("/jobs?acc%65ss_token=abc"), "/jobs?acc%65ss_token=REDACTED");
  EXPECT_EQ(loggable_target("/jobs/abc/results"), "/jobs/abc/results");
  EXPECT_EQ(loggable_target("/jobs?tokenize=1"), "/jobs?tokenize=1");
  const std::string long_target = "/x?q=" + std::string(5000, 'a');
  EXPECT_LT(loggable_target(long_target).size(), 600u);
  EXPECT_TRUE(rv::is_valid_utf8(loggable_target("/j\xff?x=\x80")));
}

// RFC 9110 13.1.2: "*" or a list of entity-tags, weakly compared (W/ ignored, the quoted
// opaque-tags equal); anything else in the field is no list, and matches nothing.
TEST(Util, IfNoneMatchIsAWeakComparisonOfAListOfEntityTags) {
  using rv::daemon::if_none_match_matches;
  const std::string etag = R"(W/"123-4.5")";
  EXPECT_TRUE(if_none_match_matches(R"(W/"123-4.5")", etag));
  EXPECT_TRUE(if_none_match_matches(R"("123-4.5")", etag)) << "the strong form, compared weakly";
  EXPECT_TRUE(if_none_match_matches("*", etag));
  EXPECT_TRUE(if_none_match_matches(" * ", etag));
  EXPECT_TRUE(if_none_match_matches(R"("x", W/"123-4.5")", etag));
  EXPECT_TRUE(if_none_match_matches(R"("x",W/"123-4.5" ,, "y")", etag)) << "empty elements and optional space";
  EXPECT_TRUE(if_none_match_matches(R"(W/"123-4.5")", R"("123-4.5")")) << "a strong current ETag";
  EXPECT_FALSE(if_none_match_matches("", etag));
  EXPECT_FALSE(if_none_match_matches(R"("x")", etag));
  EXPECT_FALSE(if_none_match_matches(R"("x", garbage"123-4.5")", etag));
  EXPECT_FALSE(if_none_match_matches(R"(xxW/"123-4.5"xx)", etag));
  EXPECT_FALSE(if_none_match_matches(R"(W/"123-4.5"xx)", etag));
  EXPECT_FALSE(if_none_match_matches(R"(W/"W/"123-4.5"")", etag));
  EXPECT_FALSE(if_none_match_matches(R"("123-4.5)", etag)) << "no closing quote";
  EXPECT_FALSE(if_none_match_matches(R"(w/"123-4.5")", etag)) << "W/ is case-sensitive";
  EXPECT_FALSE(if_none_match_matches(R"("123-4.50")", etag));
  EXPECT_FALSE(if_none_match_matches(R"("123-4.")", etag));
  EXPECT_FALSE(if_none_match_matches(R"(123-4.5)", etag)) << "not quoted";
  EXPECT_FALSE(if_none_match_matches(R"(*, "x")", etag)) << "* stands alone";
  EXPECT_FALSE(if_none_match_matches("**", etag));
}

TEST(Api, ProblemsAreShortValidAndSay503sRetryAfter) {
  const auto p = rv::daemon::problem_response(400, "t", "T", "crs '" + std::string(700000, 'W') + "\x80'", "/x");
  EXPECT_LT(p.body.size(), rv::daemon::kMaxProblemDetail + 512);
  const json doc = json::parse(p.body);
  EXPECT_NE(doc.at("detail").get<std::string>().find("(700007 bytes)"), std::string::npos);
  bool retry = false;
  for (const auto& [name, value] : rv::daemon::problem_response(503, "t", "T", "busy", "").headers)
    retry = retry || (name == "Retry-After" && value == std::to_string(rv::daemon::kRetryAfterSeconds));
  EXPECT_TRUE(retry);
  for (const auto& [name, value] : p.headers) EXPECT_NE(name, "Retry-After");
  EXPECT_NO_THROW(json::parse(rv::daemon::last_resort_problem().body));
}

TEST(Connections, TheLongestWaitingConnectionMakesRoomAndBusyOnesStay) {
  rv::daemon::ConnectionTable table(3);
  std::vector<int> closed;
  auto closer = [&](int n) { return [&closed, n] { closed.push_back(n); }; };
  const auto a = table.add(closer(1));
  const auto b = table.add(closer(2));
  const auto c = table.add(closer(3));
  table.set_waiting(a, false);  // a request in progress: never evicted
  table.set_waiting(b, false);
  table.set_waiting(b, true);  // waiting again since now: younger than c
  EXPECT_TRUE(table.make_room());
  EXPECT_EQ(closed, (std::vector<int>{3}));
  table.remove(c);
  const auto d = table.add(closer(4));
  table.set_waiting(d, false);
  EXPECT_TRUE(table.make_room());  // b is the only one waiting
  EXPECT_EQ(closed, (std::vector<int>{3, 2}));
  table.remove(b);
  const auto e = table.add(closer(5));
  table.set_waiting(e, false);
  EXPECT_FALSE(table.make_room());  // a, d, e all busy: the newcomer is refused
  table.remove(e);
  EXPECT_TRUE(table.make_room());  // below the cap again
  EXPECT_EQ(table.size(), 2u);
  EXPECT_FALSE(table.evict_oldest_waiting());
  EXPECT_EQ(rv::daemon::connection_cap(77), 77u);
  EXPECT_GE(rv::daemon::connection_cap(0), 8u);
}

TEST(Store, PersistsAcrossReopenAndFailsInterruptedJobs) {
  const auto dir = temp_dir("store");
  rv::JobRecord a;
  a.id = rv::daemon::new_job_id();
  a.process_id = "voronoi";
  a.created = a.updated = "2026-01-01T00:00:00.000Z";
  a.inputs = {{"resolution", 5}};
  a.outputs = {"ownership", "report"};
  a.transmission = {"reference", "value"};
  a.formats = {"image/tiff; application=geotiff; profile=cloud-optimized", "application/json"};
  rv::JobRecord b = a;
  b.id = rv::daemon::new_job_id();
  b.created = "2026-01-02T00:00:00.000Z";
  {
    rv::JobStore store(dir / "jobs.sqlite");
    store.insert(a);
    store.insert(b);
    EXPECT_EQ(kind_of([&] { store.insert(a); }), ErrorKind::internal);  // duplicate id
    a.status = rv::JobStatus::successful;
    a.progress = 100;
    a.report = {{"grid", {{"width", 3}}}};
    store.update(a);
    b.status = rv::JobStatus::running;
    store.update(b);
  }
  rv::JobStore store(dir / "jobs.sqlite");
  const auto got = store.get(a.id);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->status, rv::JobStatus::successful);
  EXPECT_EQ(got->report["grid"]["width"], 3);
  EXPECT_EQ(got->outputs, a.outputs);
  EXPECT_EQ(got->transmission, a.transmission);
  EXPECT_EQ(got->formats, a.formats);
  EXPECT_EQ(got->inputs, a.inputs);
  EXPECT_FALSE(store.get(rv::daemon::new_job_id()));
  const auto list = store.list(10, 0);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].id, b.id);  // newest first
  EXPECT_EQ(store.list(10, 0, {rv::JobStatus::running}).size(), 1u);
  EXPECT_EQ(store.list(1, 1).at(0).id, a.id);

  const auto failed = store.fail_interrupted("server stopped", "2026-01-03T00:00:00.000Z");
  ASSERT_EQ(failed.size(), 1u);
  EXPECT_EQ(failed[0], b.id);
  const auto bb = store.get(b.id);
  EXPECT_EQ(bb->status, rv::JobStatus::failed);
  EXPECT_EQ(bb->message, "server stopped");
  EXPECT_EQ(bb->finished, "2026-01-03T00:00:00.000Z");
  EXPECT_EQ(store.get(a.id)->status, rv::JobStatus::successful);  // finished jobs untouched
  std::filesystem::remove_all(dir);
}

json fc() {
  return json::parse(R"({"type": "FeatureCollection", "features": [
    {"type": "Feature", "properties": {"owner": "A"}, "geometry": {"type": "Point", "coordinates": [0, 0]}}]})");
}

rv::daemon::Execution parse(const json& inputs, json extra = json::object()) {
  extra["inputs"] = inputs;
  return rv::daemon::parse_execution(extra, "0123456789abcdef0123456789abcdef", rv::ServerConfig{});
}

TEST(Execute, GeoJsonGoesToVsimemAndInputsMapToTheJobSpec) {
  json in = {{"seeds", fc()},
             {"ownerField", "owner"},
             {"resolution", 0.5},
             {"extent", {{"bbox", {-1, -1, 1, 1}}, {"crs", "http://www.opengis.net/def/crs/EPSG/0/32633"}}},
             {"metric", "planar"},
             {"method", "hv-scan"},
             {"maxDistance", 100},
             {"distanceUnits", "km"},
             {"validate", true}};
  std::string path;
  {
    const auto ex = parse(in);
    ASSERT_EQ(ex.spec.seeds.paths.size(), 1u);
    path = ex.spec.seeds.paths[0];
    EXPECT_EQ(path.rfind("/vsimem/rvoronoi/0123456789abcdef0123456789abcdef/", 0), 0u) << path;
    VSIStatBufL st;
    ASSERT_EQ(VSIStatL(path.c_str(), &st), 0);
    EXPECT_EQ(static_cast<size_t>(st.st_size), fc().dump().size());
    EXPECT_EQ(ex.spec.seeds.owner_field, "owner");
    EXPECT_EQ(ex.spec.seeds.target_crs, "EPSG:32633");
    EXPECT_EQ(ex.spec.seeds.allowed_drivers,
              (std::vector<std::string>{"GeoJSON", "GPKG", "ESRI Shapefile", "FlatGeobuf"}));
    EXPECT_DOUBLE_EQ(*ex.spec.grid.resolution, 0.5);
    EXPECT_EQ(*ex.spec.grid.extent, (std::array<double, 4>{-1, -1, 1, 1}));
    EXPECT_EQ(ex.spec.metric, rv::MetricRequest::planar);
    EXPECT_EQ(ex.spec.method, rv::Method::hv_scan);
    EXPECT_DOUBLE_EQ(*ex.spec.max_distance, 100);
    EXPECT_EQ(ex.spec.distance_units, rv::DistanceUnit::km);
    EXPECT_TRUE(ex.spec.validate);
    EXPECT_EQ(ex.outputs, (std::vector<std::string>{"ownership", "distance", "report"}));
    EXPECT_EQ(ex.transmission, (std::vector<std::string>{"reference", "reference", "value"}));
    EXPECT_FALSE(ex.raw);
    EXPECT_EQ(ex.inputs_summary["seeds"][0]["features"], 1);
  }
  VSIStatBufL st;
  EXPECT_NE(VSIStatL(path.c_str(), &st), 0) << "in-memory upload outlived its job";
}

TEST(Execute, UploadsAreDecodedCheckedAndNamed) {
  // A zip with the right magic is staged under /vsizip/ (contents are GDAL's business).
  const std::string zip_b64 = "UEsDBAAAAAA=";  // "PK\3\4" + 4 zero bytes
  auto ex = parse(
      {{"seeds", json::array({fc(), {{"value", zip_b64}, {"mediaType", "application/zip"}, {"encoding", "base64"}}})},
       {"resolution", 1}});
  ASSERT_EQ(ex.spec.seeds.paths.size(), 2u);
  EXPECT_EQ(ex.spec.seeds.paths[1].rfind("/vsizip//vsimem/rvoronoi/", 0), 0u);
  EXPECT_EQ(ex.inputs_summary["seeds"][1]["bytes"], 8);
  // Wrong content for the media type: invalid_input naming the element.
  const std::string msg = message_of([&] {
    parse({{"seeds",
            json::array(
                {fc(), {{"value", zip_b64}, {"mediaType", "application/geopackage+sqlite3"}, {"encoding", "base64"}}})},
           {"resolution", 1}});
  });
  EXPECT_NE(msg.find("seeds[1]"), std::string::npos) << msg;
  EXPECT_NE(msg.find("GeoPackage"), std::string::npos) << msg;
  EXPECT_EQ(kind_of([&] {
              parse({{"seeds", {{"value", "!!"}, {"mediaType", "application/flatgeobuf"}, {"encoding", "base64"}}},
                     {"resolution", 1}});
            }),
            ErrorKind::invalid_argument);
}

TEST(Execute, NothingMakesTheServerFetchOrOpenAPath) {
  EXPECT_NE(message_of([] {
              parse({{"seeds", {{"href", "http://example.org/seeds.geojson"}}}, {"resolution", 1}});
            }).find("href"),
            std::string::npos);
  EXPECT_EQ(kind_of([] { parse({{"seeds", "/etc/passwd"}, {"resolution", 1}}); }), ErrorKind::invalid_argument);
  for (const char* crs : {"/etc/passwd", "+init=epsg:4326", "http://example.org/crs.wkt", "EPSG:4326; rm"}) {
    const std::string m = message_of([&] { parse({{"seeds", fc()}, {"resolution", 1}, {"crs", crs}}); });
    EXPECT_NE(m.find("input 'crs'"), std::string::npos) << crs << ": " << m;
  }
  EXPECT_EQ(parse({{"seeds", fc()}, {"resolution", 1}, {"crs", "EPSG:4326"}}).spec.seeds.target_crs, "EPSG:4326");
  EXPECT_EQ(parse({{"seeds", fc()}, {"resolution", 1}, {"crs", "http://www.opengis.net/def/crs/OGC/1.3/CRS84"}})
                .spec.seeds.target_crs,
            "OGC:CRS84");
}

TEST(Execute, BadInputsAreNamed) {
  struct Case {
    json inputs;
    const char* names;
  };
  const Case cases[] = {
      {{{"resolution", 1}}, "input 'seeds'"},
      {{{"seeds", fc()}}, "input 'resolution'"},
      {{{"seeds", fc()}, {"resolution", -1}}, "input 'resolution'"},
      {{{"seeds", fc()}, {"resolution", "fine"}}, "input 'resolution'"},
      {{{"seeds", fc()}, {"resolution", 1}, {"method", "magic"}}, "input 'method'"},
      {{{"seeds", fc()}, {"resolution", 1}, {"metric", "manhattan"}}, "input 'metric'"},
      {{{"seeds", fc()}, {"resolution", 1}, {"extent", {1, 2, 3}}}, "input 'extent'"},
      {{{"seeds", fc()}, {"resolution", 1}, {"extent", {3, 0, 1, 1}}}, "input 'extent'"},
      {{{"seeds", fc()}, {"resolution", 1}, {"distanceUnits", "furlong"}}, "input 'distanceUnits'"},
      {{{"seeds", fc()}, {"resolution", 1}, {"validate", "yes"}}, "input 'validate'"},
      {{{"seeds", fc()}, {"resolution", 1}, {"colour", "red"}}, "unknown input 'colour'"},
      {{{"seeds", json::array()}, {"resolution", 1}}, "input 'seeds'"},
      {{{"seeds", {{"type", "Feature"}}}, {"resolution", 1}}, "input 'seeds'"},
      {{{"seeds", fc()},
        {"resolution", 1},
        {"crs", "EPSG:4326"},
        {"extent", {{"bbox", {0, 0, 1, 1}}, {"crs", "EPSG:3857"}}}},
       "input 'extent'"},
  };
  for (const Case& c : cases) {
    const std::string m = message_of([&] { parse(c.inputs); });
    EXPECT_NE(m.find(c.names), std::string::npos) << c.inputs.dump() << " -> " << m;
  }
}

TEST(Execute, OutputsResponseAndLimits) {
  auto ex = parse({{"seeds", fc()}, {"resolution", 1}},
                  {{"outputs", {{"report", {{"transmissionMode", "reference"}}}, {"ownership", json::object()}}},
                   {"response", "document"}});
  EXPECT_EQ(ex.outputs, (std::vector<std::string>{"ownership", "report"}));
  EXPECT_EQ(ex.transmission, (std::vector<std::string>{"reference", "reference"}));
  EXPECT_TRUE(
      parse({{"seeds", fc()}, {"resolution", 1}}, {{"outputs", {{"distance", json::object()}}}, {"response", "raw"}})
          .raw);
  EXPECT_EQ(kind_of([] {
              parse({{"seeds", fc()}, {"resolution", 1}}, {{"response", "raw"}});
            }),
            ErrorKind::unsupported);
  EXPECT_EQ(kind_of([] {
              parse({{"seeds", fc()}, {"resolution", 1}}, {{"outputs", {{"nearest", json::object()}}}});
            }),
            ErrorKind::invalid_argument);
  EXPECT_EQ(
      kind_of([] {
        parse({{"seeds", fc()}, {"resolution", 1}}, {{"outputs", {{"ownership", {{"transmissionMode", "value"}}}}}});
      }),
      ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([] {
              parse({{"seeds", fc()}, {"resolution", 1}}, {{"subscriber", json::object()}});
            }),
            ErrorKind::unsupported);

  // The deliverables: formats by media type, in output order, defaults where none is asked.
  ex = parse({{"seeds", fc()},
              {"resolution", 1},
              {"limitDistances", {"12nmi", 24, {{"value", 3}, {"unit", "km"}}}},
              {"limitsPerOwner", true},
              {"simplify", 0.5}},
             {{"outputs",
               {{"preview", json::object()},
                {"limits", {{"format", {{"mediaType", "Application/GeoPackage+SQLite3"}}}}},
                {"boundaries", json::object()},
                {"margin", {{"format", {{"mediaType", "image/tiff"}}}}},
                {"nearestFeature", json::object()}}}});
  EXPECT_EQ(ex.outputs, (std::vector<std::string>{"nearestFeature", "boundaries", "limits", "margin", "preview"}));
  EXPECT_EQ(ex.formats,
            (std::vector<std::string>{rv::daemon::kMediaGeoTiff, "application/geo+json",
                                      "application/geopackage+sqlite3", rv::daemon::kMediaGeoTiff, "image/png"}));
  EXPECT_EQ(ex.spec.outputs.limit_distances, (std::vector<std::string>{"12nmi", "24", "3km"}));
  EXPECT_TRUE(ex.spec.outputs.limits_per_owner);
  EXPECT_DOUBLE_EQ(ex.spec.outputs.simplify_cells, 0.5);
  EXPECT_EQ(rv::daemon::output_file_name("limits", "application/geopackage+sqlite3"), "limits.gpkg");
  EXPECT_EQ(rv::daemon::output_file_name("boundaries", ""), "boundaries.geojson");
  EXPECT_EQ(rv::daemon::output_file_name("nearestFeature", ""), "nearest_feature.tif");
  EXPECT_EQ(kind_of([] { rv::daemon::output_file_name("preview", "application/json"); }), ErrorKind::internal);
  EXPECT_EQ(kind_of([] { rv::daemon::output_media_type("preview", "image/jpeg"); }), ErrorKind::invalid_argument);

  rv::ServerConfig small;
  small.limits.max_cells = 10'000;
  small.limits.validate_max_cells = 100;
  const json big = {{"inputs", {{"seeds", fc()}, {"resolution", 0.001}, {"extent", {0, 0, 1, 1}}}}};
  EXPECT_EQ(kind_of([&] { rv::daemon::parse_execution(big, rv::daemon::new_job_id(), small); }), ErrorKind::too_large);
  const json validate = {
      {"inputs", {{"seeds", fc()}, {"resolution", 0.05}, {"extent", {0, 0, 1, 1}}, {"validate", true}}}};
  const std::string m = message_of([&] { rv::daemon::parse_execution(validate, rv::daemon::new_job_id(), small); });
  EXPECT_NE(m.find("input 'validate'"), std::string::npos) << m;
}

}  // namespace
