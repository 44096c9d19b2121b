#include "frame_clock.h"

#include <algorithm>
#include <stdexcept>
#include <thread>

namespace nfc_viewer {

FrameClock::FrameClock(int fps, const std::string& log_path) {
    if (fps > 0)
        period_ = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / fps));
    if (!log_path.empty()) {
        log_ = std::fopen(log_path.c_str(), "w");
        if (!log_) throw std::runtime_error(log_path + ": cannot create the frame log");
        std::fprintf(log_, "# frame_ms work_ms loading\n");
    }
}

FrameClock::~FrameClock() {
    if (log_) std::fclose(log_);
}

void FrameClock::begin_frame() {
    const Clock::time_point now = Clock::now();
    if (started_) {  // the previous frame's interval is known now
        const double ms = std::chrono::duration<double, std::milli>(now - start_).count();
        intervals_ms_.push_back(ms);
        if (log_) std::fprintf(log_, "%.3f %.3f %d\n", ms, work_ms_, loading_ ? 1 : 0);
    }
    start_ = now;
    started_ = true;
}

void FrameClock::end_frame(bool loading) {
    work_ms_ = std::chrono::duration<double, std::milli>(Clock::now() - start_).count();
    loading_ = loading;
}

void FrameClock::pace() {
    if (period_.count() > 0) std::this_thread::sleep_until(start_ + period_);
}

double FrameClock::average_ms() const {
    double sum = 0;
    for (double ms : intervals_ms_) sum += ms;
    return intervals_ms_.empty() ? 0 : sum / double(intervals_ms_.size());
}

void FrameClock::print_summary() const {
    if (intervals_ms_.empty()) return;
    std::vector<double> v = intervals_ms_;
    std::sort(v.begin(), v.end());
    auto at = [&](double q) { return v[std::min(v.size() - 1, size_t(q * double(v.size())))]; };
    std::printf("frames %zu, frame ms p50 / p99 / max: %.2f / %.2f / %.2f\n", v.size() + 1, at(0.5),
                at(0.99), v.back());
}

}  // namespace nfc_viewer
