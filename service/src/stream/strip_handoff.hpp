// Internal to the streaming path (job_stream.cpp): the bounded hand-off of strip buffers
// between the thread that computes strips and the writer threads, one per file. Not part of the
// public API.
//
// Contract: the computing side takes a free buffer (take_free), fills it and hands it over
// (put_filled); close() after the last strip, then wait_finished(). Writer i takes the strips
// by fill sequence number 0, 1, ... (take_filled), writes each into its file, gives it back
// (put_done), and after the last one calls finished(); on an error it calls fail(). A buffer is
// free again only when every writer has given it back, so the writers are never more than the
// number of buffers apart (with no writers at all, put_filled frees it at once). The first error is kept: take_free
// then returns nullopt and wait_finished rethrows it. stop() (the computing side failed) makes every waiting writer's
// take_filled return nullopt. Every member is thread safe; add_free() is for set-up, before
// other threads use the object.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

namespace rv::detail {

// Seconds from t to now, on the clock the streaming path times its phases with.
inline double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

class StripHandoff {
  using Clock = std::chrono::steady_clock;

 public:
  explicit StripHandoff(int writers) : writers_(writers), done_(static_cast<size_t>(writers), false) {}

  // Computing side: a free strip buffer, or nullopt once a writer has failed. `waited` grows by
  // the seconds spent waiting.
  std::optional<int> take_free(double& waited) {
    const auto t = Clock::now();
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [&] { return error_ || !free_.empty(); });
    waited += seconds_since(t);
    if (error_) return std::nullopt;
    const int k = free_.front();
    free_.pop_front();
    return k;
  }
  void put_filled(int k) {
    {
      std::lock_guard lock(mutex_);
      if (writers_ == 0) {  // nothing to write (a job of deliverables alone): free at once
        free_.push_back(k);
      } else {
        order_.push_back(k);
        pending_[static_cast<size_t>(k)] = writers_;
      }
    }
    cv_.notify_all();
  }
  void close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    cv_.notify_all();
  }
  // Stops the writers at their next wait (the computing side failed).
  void stop() {
    {
      std::lock_guard lock(mutex_);
      stopped_ = true;
    }
    cv_.notify_all();
  }

  // Writer side: the strip filled `seq`-th (0, 1, ...); nullopt when closed and drained, or
  // stopped.
  std::optional<int> take_filled(size_t seq, double& waited) {
    const auto t = Clock::now();
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [&] { return stopped_ || closed_ || seq < first_ + order_.size(); });
    waited += seconds_since(t);
    if (stopped_ || seq >= first_ + order_.size()) return std::nullopt;
    return order_[seq - first_];
  }
  // Writer side: done with strip buffer k (its rows are in the writer's file).
  void put_done(int k, int64_t rows) {
    {
      std::lock_guard lock(mutex_);
      if (--pending_[static_cast<size_t>(k)] > 0) return;
      // Every writer takes the strips in fill order, so the last one done with a strip is done
      // with every earlier strip: this is the oldest strip in flight.
      order_.pop_front();
      ++first_;
      free_.push_back(k);
      rows_written_ += rows;
    }
    cv_.notify_all();
  }
  void fail(std::exception_ptr e) {
    {
      std::lock_guard lock(mutex_);
      if (!error_) error_ = std::move(e);
    }
    cv_.notify_all();
  }
  // Writer side, every row of its file written: waits until every writer has written all of
  // its rows (true: the files may go into place), or one failed or the writers were stopped
  // (false: none should). A file then goes into place only once no other can fail while its
  // tiles are written (an edit's copied tile that was modified, a full disk).
  bool all_written() {
    std::unique_lock lock(mutex_);
    ++written_;
    cv_.notify_all();
    cv_.wait(lock, [&] { return error_ || stopped_ || written_ == writers_; });
    return !error_ && !stopped_;
  }
  // Writer side: its file is complete and in place (`writer`: its index, 0 .. writers - 1).
  void finished(int writer) {
    {
      std::lock_guard lock(mutex_);
      ++finished_;
      done_[static_cast<size_t>(writer)] = true;
    }
    cv_.notify_all();
  }

  // Computing side, after close(): waits until every writer is done or one failed, calling
  // on_rows(rows written by all) whenever more rows are written, the last time with all of
  // them, and on_files(n) whenever writers 0 .. n - 1 have all finished, n growing to `writers`
  // (so a file's report follows those of the files before it, whichever finished first).
  // Rethrows a writer's error.
  template <class F, class G>
  void wait_finished(F&& on_rows, G&& on_files) {
    std::unique_lock lock(mutex_);
    int64_t seen = -1;
    int files_seen = 0;
    auto files_done = [&] {
      int n = 0;
      while (n < writers_ && done_[static_cast<size_t>(n)]) ++n;
      return n;
    };
    for (;;) {
      cv_.wait(lock,
               [&] { return error_ || finished_ == writers_ || rows_written_ != seen || files_done() != files_seen; });
      if (error_) std::rethrow_exception(error_);
      // Read before the callbacks let go of the lock: when every writer has finished, the rows
      // and files read now are the last ones, and are reported before returning. (Testing
      // "finished" after them could return without ever reporting the last strip's rows.)
      const bool done = finished_ == writers_;
      const int files = files_done();
      if (rows_written_ != seen) {
        seen = rows_written_;
        lock.unlock();
        on_rows(seen);
        lock.lock();
      }
      if (files != files_seen) {
        files_seen = files;
        lock.unlock();
        on_files(files);
        lock.lock();
      }
      if (done) return;
    }
  }
  template <class F>
  void wait_finished(F&& on_rows) {
    wait_finished(std::forward<F>(on_rows), [](int) {});
  }
  std::exception_ptr error() {
    std::lock_guard lock(mutex_);
    return error_;
  }
  void add_free(int k) {
    free_.push_back(k);
    if (pending_.size() <= static_cast<size_t>(k)) pending_.resize(static_cast<size_t>(k) + 1, 0);
  }

 private:
  const int writers_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<int> free_;
  std::deque<int> order_;     // strips in flight (filled, some writer not done), in fill order
  size_t first_ = 0;          // the fill sequence number of order_.front()
  std::vector<int> pending_;  // per strip buffer: writers not yet done with it
  bool closed_ = false, stopped_ = false;
  int finished_ = 0;
  int written_ = 0;         // writers with every row written (all_written)
  std::vector<bool> done_;  // per writer: finished
  int64_t rows_written_ = 0;
  std::exception_ptr error_;
};

}  // namespace rv::detail
