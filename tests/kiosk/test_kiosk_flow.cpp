// The visitor flow's state machine (appliance/ui/kiosk_flow.hpp): every transition, every timeout,
// and the events that must change nothing.
#include <gtest/gtest.h>

#include "appliance/ui/kiosk_flow.hpp"

namespace glint::ui {
namespace {

TimeoutsSection timeouts() {
    TimeoutsSection t;
    t.attract_s = 0;
    t.capture_s = 100;
    t.processing_s = 30;
    t.ar_idle_s = 40;
    t.message_s = 5;
    return t;
}

TEST(KioskFlow, AVisitorGoesThroughEveryStateAndBack) {
    KioskFlow flow(timeouts(), 3);
    EXPECT_EQ(flow.state(), KioskState::Attract);
    ASSERT_TRUE(flow.button(1.0));
    EXPECT_EQ(flow.state(), KioskState::Capture);
    ASSERT_TRUE(flow.scan_finished(50.0, "scan complete"));
    EXPECT_EQ(flow.state(), KioskState::Processing);
    ASSERT_TRUE(flow.maps_ready(51.5));
    EXPECT_EQ(flow.state(), KioskState::Ar);
    EXPECT_FALSE(flow.tick(51.5 + 39.0));
    const auto idle = flow.tick(51.5 + 40.5);
    ASSERT_TRUE(idle);
    EXPECT_EQ(idle->reason, "idle");
    EXPECT_EQ(flow.state(), KioskState::Attract);
    ASSERT_EQ(flow.history().size(), 4u);
    EXPECT_EQ(flow.history()[0].to, KioskState::Capture);
    EXPECT_EQ(flow.history()[3].to, KioskState::Attract);
    EXPECT_EQ(flow.message(100.0), "");  // an idle return is no error
}

TEST(KioskFlow, TheButtonCyclesTheMaterialsInArAndKeepsTheVisitorThere) {
    KioskFlow flow(timeouts(), 3);
    flow.button(0);
    flow.scan_finished(10, "scan complete");
    flow.maps_ready(11);
    EXPECT_EQ(flow.material(), 0);
    EXPECT_FALSE(flow.button(12));
    EXPECT_EQ(flow.material(), 1);
    flow.button(13);
    EXPECT_EQ(flow.material(), 2);
    flow.button(14);
    EXPECT_EQ(flow.material(), 0);
    EXPECT_EQ(flow.state(), KioskState::Ar);
    // A press is input: the idle timeout counts from it.
    EXPECT_FALSE(flow.tick(14 + 39));
    EXPECT_TRUE(flow.tick(14 + 41));
}

TEST(KioskFlow, EventsOutOfTheirStateChangeNothing) {
    KioskFlow flow(timeouts(), 3);
    EXPECT_FALSE(flow.scan_finished(1, "scan complete"));
    EXPECT_FALSE(flow.maps_ready(1));
    EXPECT_EQ(flow.state(), KioskState::Attract);
    flow.button(2);
    EXPECT_FALSE(flow.button(3));  // a second press during the scan
    EXPECT_FALSE(flow.maps_ready(4));
    EXPECT_EQ(flow.state(), KioskState::Capture);
    EXPECT_TRUE(flow.history().size() == 1);
}

TEST(KioskFlow, TimeoutsAndFailuresReturnToAttractWithAMessageForAWhile) {
    KioskFlow flow(timeouts(), 3);
    flow.button(0);
    EXPECT_FALSE(flow.tick(99));
    const auto t = flow.tick(100.5);
    ASSERT_TRUE(t);
    EXPECT_EQ(t->from, KioskState::Capture);
    EXPECT_EQ(flow.state(), KioskState::Attract);
    EXPECT_EQ(flow.message(101), "message.capture_timeout");
    EXPECT_EQ(flow.message(106), "");  // message_s = 5

    flow.button(200);
    flow.scan_finished(210, "scan complete");
    EXPECT_TRUE(flow.tick(241));
    EXPECT_EQ(flow.message(242), "message.processing_timeout");

    flow.button(300);
    const auto f = flow.failure(301, "message.capture_failed", "camera: no frames for 2 s");
    ASSERT_TRUE(f);
    EXPECT_EQ(f->reason, "camera: no frames for 2 s");
    EXPECT_EQ(flow.message(302), "message.capture_failed");
    // The next visitor's press clears the last one's apology.
    flow.button(303);
    EXPECT_EQ(flow.message(303.5), "");
}

TEST(KioskFlow, AttractRestartsOnlyWhenItsTimeoutIsSet) {
    TimeoutsSection t = timeouts();
    KioskFlow forever(t, 3);
    EXPECT_FALSE(forever.tick(1e6));
    t.attract_s = 60;
    KioskFlow periodic(t, 3);
    EXPECT_FALSE(periodic.tick(59));
    const auto r = periodic.tick(61);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->to, KioskState::Attract);
    EXPECT_EQ(periodic.entered_s(), 61);
}

TEST(KioskFlow, EveryVisitorStartsOnTheFirstMaterial) {
    KioskFlow flow(timeouts(), 3);
    flow.button(0);
    flow.scan_finished(1, "scan complete");
    flow.maps_ready(2);
    flow.button(3);
    EXPECT_EQ(flow.material(), 1);
    flow.tick(100);  // idle -> ATTRACT
    flow.button(101);
    flow.scan_finished(102, "scan complete");
    flow.maps_ready(103);
    EXPECT_EQ(flow.material(), 0);
}

TEST(KioskFlow, AScanWaitingForADeviceDoesNotTimeOutUntilTheWaitIsTooLong) {
    KioskFlow flow(timeouts(), 3);  // capture_s = 100
    ASSERT_TRUE(flow.button(0.0));
    flow.set_paused(60.0, true, "message.sensor_problem");
    EXPECT_TRUE(flow.paused());
    EXPECT_FALSE(flow.tick(120.0));  // 120 s in CAPTURE, 60 of them waiting: no timeout
    flow.set_paused(130.0, false);
    EXPECT_FALSE(flow.paused());
    EXPECT_DOUBLE_EQ(flow.paused_total_s(), 70.0);
    EXPECT_FALSE(flow.tick(165.0));  // 95 s of scanning
    const auto timeout = flow.tick(171.0);  // 101 s of scanning
    ASSERT_TRUE(timeout);
    EXPECT_EQ(flow.message(172.0), "message.capture_timeout");

    // A wait longer than the scan's own limit gives up with the device's message.
    KioskFlow stuck(timeouts(), 3);
    ASSERT_TRUE(stuck.button(0.0));
    stuck.set_paused(10.0, true, "message.sensor_problem");
    EXPECT_FALSE(stuck.tick(109.0));
    const auto given_up = stuck.tick(111.0);
    ASSERT_TRUE(given_up);
    EXPECT_EQ(stuck.state(), KioskState::Attract);
    EXPECT_EQ(stuck.message(112.0), "message.sensor_problem");
    EXPECT_FALSE(stuck.paused());

    // Outside CAPTURE a pause is ignored.
    KioskFlow idle(timeouts(), 3);
    idle.set_paused(1.0, true);
    EXPECT_FALSE(idle.paused());
}

TEST(KioskFlow, StateNamesAreTheOnesSummaryJsonUses) {
    EXPECT_STREQ(kiosk_state_name(KioskState::Attract), "ATTRACT");
    EXPECT_STREQ(kiosk_state_name(KioskState::Capture), "CAPTURE");
    EXPECT_STREQ(kiosk_state_name(KioskState::Processing), "PROCESSING");
    EXPECT_STREQ(kiosk_state_name(KioskState::Ar), "AR");
}

}  // namespace
}  // namespace glint::ui
