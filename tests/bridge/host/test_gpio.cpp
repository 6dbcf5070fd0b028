// GPIO buttons and lamps on the fake chip, on a virtual clock; the libgpiod backend's error on a
// chip that is not there.
#include <gtest/gtest.h>

#include <filesystem>
#include <unistd.h>

#include "firmware_bridge/host/gpio_lines.hpp"
#include "firmware_bridge/recording/reader.hpp"

namespace glint::host {
namespace {

constexpr std::int64_t ms(double v) { return std::int64_t(v * 1e6); }

struct ButtonRig {
    recording::VirtualClock clock{0};
    FakeGpioChip chip{clock};
    std::vector<ButtonEvent> events;
    ButtonService service{chip, {5, 6}, /*active_low=*/true, clock};
    ButtonRig() {
        service.set_callback([this](const ButtonEvent& e) { events.push_back(e); });
    }
    void at(double t_ms) {
        clock.sleep_until_us(std::uint64_t(t_ms * 1000));
        service.poll();
    }
};

TEST(Gpio, ABouncingButtonGivesOnePressAndOneReleaseAtTheFirstEdges) {
    ButtonRig r;
    // Active low: the contact pulls the line low. Press at 100 ms with bounce, release at 300 ms.
    for (auto [t, high] : std::vector<std::pair<double, bool>>{
             {100.0, false}, {100.5, true}, {101.2, false}, {101.8, true}, {102.5, false}})
        r.chip.inject(5, high, ms(t));
    r.at(110);  // still inside the debounce window after the last bounce
    EXPECT_TRUE(r.events.empty());
    r.at(130);
    ASSERT_EQ(r.events.size(), 1u);
    EXPECT_TRUE(r.events[0].pressed);
    EXPECT_EQ(r.events[0].line, 5u);
    EXPECT_EQ(r.events[0].t_ns, ms(100));
    for (auto [t, high] : std::vector<std::pair<double, bool>>{{300.0, true}, {300.7, false}, {301.5, true}})
        r.chip.inject(5, high, ms(t));
    r.at(340);
    ASSERT_EQ(r.events.size(), 2u);
    EXPECT_FALSE(r.events[1].pressed);
    EXPECT_EQ(r.events[1].t_ns, ms(300));
}

TEST(Gpio, AGlitchShorterThanTheWindowIsNothing) {
    ButtonRig r;
    r.chip.inject(6, false, ms(50));
    r.chip.inject(6, true, ms(53));  // 3 ms spike of "pressed"
    r.at(200);
    EXPECT_TRUE(r.events.empty());
}

TEST(Gpio, TwoButtonsAreIndependent) {
    ButtonRig r;
    r.chip.inject(5, false, ms(10));
    r.chip.inject(6, false, ms(12));
    r.chip.inject(6, true, ms(80));
    r.at(150);
    ASSERT_EQ(r.events.size(), 3u);
    EXPECT_EQ(r.events[0].line, 5u);
    EXPECT_EQ(r.events[1].line, 6u);
    EXPECT_TRUE(r.events[1].pressed);
    EXPECT_FALSE(r.events[2].pressed);
    EXPECT_EQ(r.events[2].t_ns, ms(80));
}

TEST(Gpio, EveryRawEdgeIsRecorded) {
    const std::filesystem::path file =
        std::filesystem::temp_directory_path() / ("glint-gpio-" + std::to_string(::getpid()) + ".glrec");
    {
        ButtonRig r;
        recording::RecorderOptions o;
        o.header.transport = recording::Transport::Gpio;
        recording::Recorder rec(file.string(), o, r.clock);
        r.service.set_recorder(&rec);
        r.chip.inject(5, false, ms(10));
        r.chip.inject(5, true, ms(10.4));
        r.chip.inject(5, false, ms(11));
        r.at(60);
        ASSERT_TRUE(rec.close());
    }
    recording::RecordingReader reader(file.string());
    int gpio = 0;
    while (const auto rec = reader.next())
        if (std::holds_alternative<recording::GpioEventRecord>(rec->body)) {
            const auto& g = std::get<recording::GpioEventRecord>(rec->body);
            EXPECT_EQ(g.line, 5u);
            EXPECT_EQ(g.chip, "fake-gpiochip");
            ++gpio;
        }
    EXPECT_EQ(gpio, 3);
    std::filesystem::remove(file);
}

TEST(Gpio, LampPatternsFollowTheClock) {
    recording::VirtualClock clock(1'000'000);
    FakeGpioChip chip(clock);
    LampDriver lamps(chip, {20, 21}, clock);
    lamps.set_pattern(20, LampPattern::blink(ms(200), 0.25));  // on 50 ms of every 200 ms
    lamps.set_pattern(21, LampPattern::sequence({{true, ms(100)}, {false, ms(50)}, {true, ms(50)}, {false, ms(300)}}));
    const auto at = [&](double t_ms) {
        clock.sleep_until_us(1'000'000 + std::uint64_t(t_ms * 1000));
        lamps.update();
    };
    at(0);
    EXPECT_TRUE(chip.output(20));
    EXPECT_TRUE(chip.output(21));
    at(49);
    EXPECT_TRUE(chip.output(20));
    at(50);
    EXPECT_FALSE(chip.output(20));
    at(120);
    EXPECT_FALSE(chip.output(21));
    at(160);
    EXPECT_TRUE(chip.output(21));
    at(210);
    EXPECT_TRUE(chip.output(20));   // the next blink period
    EXPECT_FALSE(chip.output(21));
    at(510);
    EXPECT_TRUE(chip.output(21));   // the sequence repeats after 500 ms
    // Only changes are written.
    EXPECT_EQ(chip.output_changes(20).size(), 4u);  // on (0), off (50), on (210), off (510)
    lamps.set_pattern(20, LampPattern::off());
    at(520);
    EXPECT_FALSE(chip.output(20));
}

TEST(Gpio, AChipThatIsNotThereIsAClearError) {
    try {
        LibgpiodChip chip("/dev/gpiochip97");
        FAIL() << "opened a chip that does not exist";
    } catch (const GpioError& e) {
        EXPECT_NE(std::string(e.what()).find("/dev/gpiochip97"), std::string::npos) << e.what();
    }
}

TEST(Gpio, TheFakeRefusesLinesThatWereNotRequested) {
    recording::VirtualClock clock(0);
    FakeGpioChip chip(clock);
    EXPECT_THROW(chip.inject(3, true, 0), GpioError);
    EXPECT_THROW(chip.set_output(3, true), GpioError);
}

}  // namespace
}  // namespace glint::host
