// glint-recording: inspect, replay, verify and generate recorded sensor files (FORMAT.md).
//   glint-recording info FILE       header, record counts, time span, damage
//   glint-recording dump FILE       one line per record
//   glint-recording play FILE       decoded frames with receive times (--fast or --realtime)
//   glint-recording verify FILE     CRCs, and replay == decoded records (a file without a byte
//                                   stream: nothing to replay against); exit 1 on a mismatch
//   glint-recording generate FILE   the deterministic synthetic session (data/sessions/)
// Exit codes: 0 success, 1 verification failed or an I/O failure, 2 unusable input.
#include <CLI/CLI.hpp>

#include <cinttypes>
#include <cstdio>
#include <ctime>
#include <map>
#include <memory>
#include <string>

#include "firmware_bridge/recording/player.hpp"
#include "firmware_bridge/recording/reader.hpp"
#include "firmware_bridge/recording/session_generator.hpp"
#include "firmware_bridge/recording/text.hpp"
#include "firmware_bridge/recording/verify.hpp"

namespace {

using namespace glint::recording;

void warn(const ReadIssue& issue) { std::fprintf(stderr, "warning: %s\n", issue.message.c_str()); }

std::string utc_text(std::int64_t unix_us) {
    const std::time_t seconds = static_cast<std::time_t>(unix_us / 1'000'000);
    std::tm tm{};
    gmtime_r(&seconds, &tm);
    char text[64];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return text;
}

int run_info(const std::string& path) {
    RecordingReader reader(path);
    const FileHeader& h = reader.header();
    std::printf("file         %s (%" PRIu64 " bytes)\n", path.c_str(), reader.file_size());
    std::printf("format       %u.%u, header %" PRIu32 " bytes\n", h.format_major, h.format_minor, h.header_size);
    std::printf("created      %s (unix %" PRId64 " us), appliance monotonic %" PRIu64 " us\n",
                utc_text(h.created_unix_us).c_str(), h.created_unix_us, h.created_monotonic_us);
    std::printf("transport    %s, device \"%s\", baud %" PRIu32 "\n", transport_name(h.transport),
                printable(h.device).c_str(), h.baud);
    std::printf("protocol     %u.%u\n", h.protocol_major, h.protocol_minor);
    std::string types;
    for (const std::uint8_t t : h.decoded_types) types += std::string(types.empty() ? "" : " ") + glint::protocol::type_name(t);
    std::printf("decoded      %s\n", types.empty() ? "(none)" : types.c_str());
    for (const Note& n : h.notes) std::printf("note         %s=%s\n", printable(n.key).c_str(), printable(n.value).c_str());

    std::map<std::string, std::uint64_t> counts;
    std::map<std::string, std::uint64_t> messages;
    std::uint64_t rx_bytes = 0, tx_bytes = 0, first = 0, last = 0;
    bool any_time = false;
    while (const auto record = reader.next()) {
        ++counts[record_type_name(record_type_of(record->body))];
        if (const auto* raw = std::get_if<RawBytesRecord>(&record->body))
            (raw->direction == Direction::Received ? rx_bytes : tx_bytes) += raw->bytes.size();
        if (const auto* m = std::get_if<DecodedMessageRecord>(&record->body))
            ++messages[glint::protocol::type_name(static_cast<std::uint8_t>(m->message.type))];
        if (const auto t = record_time_us(record->body)) {
            if (!any_time) first = *t;
            any_time = true;
            last = *t;
        }
    }
    for (const auto& [name, n] : counts) std::printf("records      %-16s %" PRIu64 "\n", name.c_str(), n);
    for (const auto& [name, n] : messages) std::printf("messages     %-16s %" PRIu64 "\n", name.c_str(), n);
    std::printf("raw bytes    received %" PRIu64 ", sent %" PRIu64 "\n", rx_bytes, tx_bytes);
    if (any_time)
        std::printf("time span    %" PRIu64 " .. %" PRIu64 " us (%.6f s, appliance monotonic)\n", first, last,
                    static_cast<double>(last - first) * 1e-6);
    std::printf("damage       %zu issue(s)\n", reader.issues().size());
    for (const ReadIssue& issue : reader.issues()) warn(issue);
    return 0;
}

int run_dump(const std::string& path, std::size_t max_hex) {
    RecordingReader reader(path);
    std::size_t issues_seen = 0;
    auto flush_issues = [&] {
        for (; issues_seen < reader.issues().size(); ++issues_seen) warn(reader.issues()[issues_seen]);
    };
    while (const auto record = reader.next()) {
        flush_issues();
        std::printf("@%" PRIu64 " %s\n", record->offset, describe_record(record->body, max_hex).c_str());
    }
    flush_issues();
    return 0;
}

class PrintSink final : public PlaybackSink {
public:
    explicit PrintSink(bool all_records) : all_records_(all_records) {}
    void on_frame(std::uint64_t t, const glint::protocol::FrameEvent& e) override {
        if (!have_first_) {
            first_ = t;
            have_first_ = true;
        }
        const double rel = static_cast<double>(t - first_) * 1e-6;
        if (e.status == glint::protocol::FrameStatus::Ok)
            std::printf("t=%" PRIu64 "us +%.6fs offset=%" PRIu64 " seq=%u%s %s\n", t, rel, e.offset, e.seq,
                        e.lost_before ? (" lost_before=" + std::to_string(e.lost_before)).c_str() : "",
                        describe_message(e.message).c_str());
        else
            std::printf("t=%" PRIu64 "us +%.6fs offset=%" PRIu64 " size=%" PRIu32 " rejected: %s%s\n", t, rel,
                        e.offset, e.size, glint::protocol::status_name(e.status),
                        e.header_valid ? (std::string(" type ") + glint::protocol::type_name(e.type)).c_str() : "");
        std::fflush(stdout);  // --realtime: show each frame when it is due
    }
    void on_record(const Record& r) override {
        const bool always = std::holds_alternative<MarkerRecord>(r.body) || std::holds_alternative<GpioEventRecord>(r.body) ||
                            std::holds_alternative<StreamRestartRecord>(r.body);
        if (always || (all_records_ && !std::holds_alternative<RawBytesRecord>(r.body)))
            std::printf("# @%" PRIu64 " %s\n", r.offset, describe_record(r.body).c_str());
    }
    void on_issue(const ReadIssue& issue) override { warn(issue); }

private:
    bool all_records_;
    bool have_first_ = false;
    std::uint64_t first_ = 0;
};

int run_play(const std::string& path, bool realtime, bool all_records) {
    RecordingReader reader(path);
    std::unique_ptr<Clock> clock;
    if (realtime) clock = std::make_unique<SteadyClock>();
    else clock = std::make_unique<VirtualClock>();
    PrintSink sink(all_records);
    Player player(reader, *clock);
    const PlaybackResult result = player.play(sink);
    std::printf("decoder statistics (%" PRIu64 " records, %" PRIu64 " stream restarts, %" PRIu64 " issues):\n%s",
                result.records, result.stream_restarts, result.issues, describe_stats(result.stats).c_str());
    return 0;
}

int run_verify(const std::string& path, bool allow_torn_tail) {
    RecordingReader reader(path);
    const VerifyReport report = verify_recording(reader);
    std::size_t fatal_issues = 0;
    for (const ReadIssue& issue : report.issues) {
        warn(issue);
        if (!(allow_torn_tail && issue.kind == IssueKind::TornTail)) ++fatal_issues;
    }
    for (const std::string& m : report.mismatches) std::printf("mismatch: %s\n", m.c_str());
    if (report.mismatches_not_shown) std::printf("... and %" PRIu64 " more mismatches\n", report.mismatches_not_shown);
    if (report.decoded_only)
        std::printf("%s: %" PRIu64 " records, %zu issue(s); %" PRIu64
                    " decoded messages recorded (%s: no byte stream, nothing to replay them against)\n",
                    path.c_str(), report.playback.records, report.issues.size(), report.recorded_messages,
                    transport_name(reader.header().transport));
    else
        std::printf("%s: %" PRIu64 " records, %zu issue(s); %" PRIu64 " decoded messages recorded, %" PRIu64
                    " replayed, %" PRIu64 " equal\n",
                    path.c_str(), report.playback.records, report.issues.size(), report.recorded_messages,
                    report.replayed_messages, report.matching_messages);
    const bool ok = fatal_issues == 0 && report.replay_matches();
    std::printf("%s\n", ok ? "OK" : "FAILED");
    return ok ? 0 : 1;
}

int run_generate(const std::string& path, const SessionOptions& options, bool force) {
    const SessionSummary s = generate_session(path, options, force);
    std::printf("%s: %" PRIu64 " frames sent, %" PRIu64 " garbage bursts (%" PRIu64 " bytes), %" PRIu64
                " chunks received, %" PRIu64 " messages decoded\n",
                path.c_str(), s.frames_sent, s.garbage_bursts, s.garbage_bytes, s.chunks, s.decoded);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"glint-recording: inspect, replay, verify and generate recorded sensor files "
                 "(firmware_bridge/recording/FORMAT.md)."};
    app.set_version_flag("--version", "glint-recording " GLINT_VERSION, "Print the version");
    app.require_subcommand(1);
    std::string file;
    std::size_t max_hex = 32;
    bool realtime = false, fast = false, all_records = false, allow_torn_tail = false, force = false;
    SessionOptions session;

    CLI::App* info = app.add_subcommand("info", "Print the header, record counts, time span and damage.");
    info->add_option("FILE", file, "recording")->required();
    CLI::App* dump = app.add_subcommand("dump", "Print every record, one line each, with its byte offset.");
    dump->add_option("FILE", file, "recording")->required();
    dump->add_option("--hex-bytes", max_hex, "raw bytes shown per record")->capture_default_str();
    CLI::App* play = app.add_subcommand(
        "play", "Replay the received bytes through the protocol decoder; print frames with receive times.");
    play->add_option("FILE", file, "recording")->required();
    auto* fast_flag = play->add_flag("--fast", fast, "as fast as possible on a virtual clock (default)");
    play->add_flag("--realtime", realtime, "at recorded speed (sleeps on CLOCK_MONOTONIC)")->excludes(fast_flag);
    play->add_flag("--all", all_records, "also print decoded-message and unknown records");
    CLI::App* verify = app.add_subcommand(
        "verify", "Check every CRC and that replaying the raw bytes reproduces the decoded records; exit 1 if not.");
    verify->add_option("FILE", file, "recording")->required();
    verify->add_flag("--allow-torn-tail", allow_torn_tail, "accept a file whose last record was cut (power loss)");
    CLI::App* generate = app.add_subcommand("generate", "Write the deterministic synthetic session (same options, same bytes).");
    generate->add_option("FILE", file, "output recording")->required();
    generate->add_option("--seed", session.seed, "pseudo-random seed")->capture_default_str();
    generate->add_option("--duration-ms", session.duration_ms, "board time covered, ms")
        ->capture_default_str()->check(CLI::Range(1u, 600'000u));
    generate->add_option("--orientation-hz", session.orientation_hz, "Orientation rate")
        ->capture_default_str()->check(CLI::Range(1u, 1000u));
    generate->add_option("--raw-imu-hz", session.raw_imu_hz, "RawImu rate")
        ->capture_default_str()->check(CLI::Range(1u, 1000u));
    generate->add_option("--baud", session.baud, "serial line rate, bit/s")
        ->capture_default_str()->check(CLI::Range(1200u, 4'000'000u));
    generate->add_flag("--force", force, "replace an existing file");

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);  // --help (of the tool or a subcommand)
        std::fprintf(stderr, "glint-recording: error: %s (see glint-recording --help)\n", e.what());
        return 2;
    }

    try {
        if (info->parsed()) return run_info(file);
        if (dump->parsed()) return run_dump(file, max_hex);
        if (play->parsed()) return run_play(file, realtime, all_records);
        if (verify->parsed()) return run_verify(file, allow_torn_tail);
        if (generate->parsed()) return run_generate(file, session, force);
    } catch (const RecordingError& e) {
        std::fprintf(stderr, "glint-recording: error: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "glint-recording: failed: %s\n", e.what());
        return 1;
    }
    return 2;
}
