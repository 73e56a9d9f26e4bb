#include "rayclass/core/helper_threads.h"

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace rayclass {

namespace {

// One OnHelpers call's calls: those not begun are [next, n).
struct Job {
    const std::function<void(int)>* f = nullptr;
    int n = 0;
    int next = 1;
    int running = 0;  // begun by helpers, not yet done
    std::exception_ptr error;
};

class Helpers {
  public:
    static Helpers& Get() {
        static Helpers helpers;
        return helpers;
    }

    void Run(int n, const std::function<void(int)>& f) {
        Job job;
        job.f = &f;
        job.n = n;
        {
            std::lock_guard lock(mutex_);
            jobs_.push_back(&job);
            // Concurrent and nested calls each find enough idle helpers.
            for (int i = idle_; i < n - 1; ++i) threads_.emplace_back([this] { Serve(); });
        }
        work_.notify_all();
        Call(job, 0);
        std::unique_lock lock(mutex_);
        while (job.next < job.n) {
            const int t = job.next++;
            lock.unlock();
            Call(job, t);
            lock.lock();
        }
        jobs_.erase(std::find(jobs_.begin(), jobs_.end(), &job));
        done_.wait(lock, [&] { return job.running == 0; });
        if (job.error) std::rethrow_exception(job.error);
    }

    ~Helpers() {
        {
            std::lock_guard lock(mutex_);
            stop_ = true;
        }
        work_.notify_all();
        for (std::thread& t : threads_) t.join();
    }

  private:
    Helpers() = default;

    // A call of `job` not begun: the first job with one.
    Job* Waiting() const {
        for (Job* job : jobs_) {
            if (job->next < job->n) return job;
        }
        return nullptr;
    }

    // Records the first exception; the calls not begun are then left out.
    void Call(Job& job, int t) {
        try {
            (*job.f)(t);
        } catch (...) {
            std::lock_guard lock(mutex_);
            if (!job.error) job.error = std::current_exception();
            job.next = job.n;
        }
    }

    void Serve() {
        std::unique_lock lock(mutex_);
        for (;;) {
            ++idle_;
            work_.wait(lock, [&] { return stop_ || Waiting(); });
            --idle_;
            if (stop_) return;
            Job& job = *Waiting();
            const int t = job.next++;
            ++job.running;
            lock.unlock();
            Call(job, t);
            lock.lock();
            if (--job.running == 0) done_.notify_all();
        }
    }

    std::mutex mutex_;
    std::condition_variable work_, done_;
    std::vector<Job*> jobs_;
    std::vector<std::thread> threads_;
    int idle_ = 0;
    bool stop_ = false;
};

}  // namespace

void OnHelpers(int n, const std::function<void(int)>& f) {
    if (n <= 1) {
        if (n == 1) f(0);
        return;
    }
    Helpers::Get().Run(n, f);
}

}  // namespace rayclass
