// The frame loop's clock: paces frames to --fps, measures each frame, and writes --frame-log.
// A frame's time is the interval from its start to the next frame's start (what a viewer sees:
// pacing included); its work time is from its start to its present (fence waits included).
#pragma once

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

namespace nfc_viewer {

class FrameClock {
public:
    // fps 0: no pacing. log_path empty: no log. Throws if the log cannot be created.
    FrameClock(int fps, const std::string& log_path);
    ~FrameClock();
    FrameClock(const FrameClock&) = delete;
    FrameClock& operator=(const FrameClock&) = delete;

    void begin_frame();
    // `loading`: some asset was still streaming or refining during this frame.
    void end_frame(bool loading);
    // Sleeps until the next frame is due.
    void pace();

    double last_ms() const { return intervals_ms_.empty() ? 0 : intervals_ms_.back(); }
    double average_ms() const;
    // "frames N, frame ms p50 / p99 / max: ..." on stdout.
    void print_summary() const;

private:
    using Clock = std::chrono::steady_clock;
    Clock::duration period_{};
    std::FILE* log_ = nullptr;
    Clock::time_point start_{};
    bool started_ = false;
    double work_ms_ = 0;
    bool loading_ = false;
    std::vector<double> intervals_ms_;
};

}  // namespace nfc_viewer
