// Comm: the rcomm region (layout, mode, shm_group, owner check), the seqlock of
// navkit_rcomm_slot.h, and the planner library libnavkit_rcomm.so against the host's side.
#include <gtest/gtest.h>

#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <sys/wait.h>
#include <grp.h>
#include <string>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "navkit/comm.hpp"
#include "navkit_rcomm.h"
#include "navkit_rcomm_slot.h"

using namespace navkit;

static std::string unique_name(const char *what)
{
    return "/nk-gtest-" + std::string(what) + "-" + std::to_string(getpid());
}

TEST(Comm, RegionLayoutModeAndUnlink)
{
    const std::string name = unique_name("layout");
    {
        Comm c(name, "");
        c.init();
        struct stat st;
        ASSERT_EQ(stat(("/dev/shm" + name).c_str(), &st), 0);
        EXPECT_EQ(st.st_mode & 0777, 0600u);
        EXPECT_EQ(st.st_size, static_cast<off_t>(NAVKIT_RCOMM_SIZE));
        navkit_rcomm_t *r = navkit_rcomm_open(name.c_str());
        EXPECT_STREQ(navkit_rcomm_error(r), "");
        navkit_rcomm_close(r);
        c.shutdown();
        EXPECT_NE(stat(("/dev/shm" + name).c_str(), &st), 0) << "removed at shutdown";
    }
}

TEST(Comm, PlannerHeaderRoundTrip)
{
    const std::string name = unique_name("roundtrip");
    Comm c(name, "");
    c.init();
    navkit_rcomm_t *r = navkit_rcomm_open(name.c_str());
    ASSERT_STREQ(navkit_rcomm_error(r), "");

    navkit_lisp_cmd_t out;
    EXPECT_FALSE(c.read_lisp_cmd(&out)) << "nothing written yet";
    navkit_lisp_cmd_t in;
    navkit_lisp_cmd_defaults(&in);
    in.time_tag = 4242;
    in.fwd_cmd = 1;
    in.distance = -2000000000;
    in.dio_active = 0x9;
    int32_t w[NAVKIT_LISP_CMD_WORDS];
    navkit_lisp_cmd_pack(&in, w);
    const uint32_t hb0 = c.planner_heartbeat();
    ASSERT_EQ(navkit_rcomm_write_cmd(r, w), 0);
    ASSERT_TRUE(c.read_lisp_cmd(&out));
    EXPECT_EQ(out.time_tag, 4242);
    EXPECT_EQ(out.distance, -2000000000);
    EXPECT_EQ(out.dio_active, 0x9);
    EXPECT_EQ(c.planner_heartbeat(), hb0 + 1) << "write_cmd beats";

    navkit_lisp_data_t d;
    navkit_lisp_data_defaults(&d);
    d.frame = 77;
    d.ir_range[3] = 555;
    c.send_lisp_data(d);
    c.set_host_heartbeat(77);
    int32_t dw[NAVKIT_LISP_DATA_WORDS];
    ASSERT_EQ(navkit_rcomm_read_data(r, dw), 1);
    navkit_lisp_data_t back;
    navkit_lisp_data_unpack(dw, &back);
    EXPECT_EQ(back.frame, 77);
    EXPECT_EQ(back.ir_range[3], 555);
    uint32_t hb = 0;
    ASSERT_EQ(navkit_rcomm_host_heartbeat(r, &hb), 0);
    EXPECT_EQ(hb, 77u);

    int32_t ew[NAVKIT_EMOTION_WORDS] = {1, 0, 50, 60, 0, 0, 0, 1};
    ASSERT_EQ(navkit_rcomm_write_emotion(r, ew), 0);
    navkit_emotion_t e;
    ASSERT_TRUE(c.read_emotion(&e));
    EXPECT_EQ(e.happiness, 50);
    EXPECT_EQ(e.talking, 1);
    navkit_rcomm_close(r);
}

TEST(Comm, SeqlockReaderNeverTakesAWriteInProgress)
{
    alignas(4) uint8_t region[64] = {};
    const int32_t msg[2] = {0x04030201, -8};
    int32_t out[2];
    EXPECT_EQ(navkit_rcomm_slot_read(region, 0, 4, out, 2), 0) << "seq 0: never written";
    navkit_rcomm_slot_write(region, 0, 4, msg, 2);
    EXPECT_EQ(navkit_get_u32(region), 2u);
    EXPECT_EQ(region[4], 0x01) << "the region is little-endian";
    ASSERT_EQ(navkit_rcomm_slot_read(region, 0, 4, out, 2), 1);
    EXPECT_EQ(std::memcmp(out, msg, sizeof msg), 0);
    navkit_put_u32(region, 3); // a writer stopped half way
    EXPECT_EQ(navkit_rcomm_slot_read(region, 0, 4, out, 2), 0);
    navkit_rcomm_slot_write(region, 0, 4, msg, 2);
    EXPECT_EQ(navkit_get_u32(region), 6u) << "the next writer skips the odd value";
}

TEST(Comm, RefusesARegionOfAnotherUser)
{
    if (geteuid() != 0) {
        GTEST_SKIP() << "needs root to make a region owned by another user";
    }
    const std::string name = unique_name("foreign");
    const int fd = shm_open(name.c_str(), O_RDWR | O_CREAT | O_EXCL, 0600);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(fchown(fd, 65534, 65534), 0);
    close(fd);
    Comm c(name, "");
    try {
        c.init();
        FAIL() << "accepted another user's region";
    } catch (const std::runtime_error &e) {
        EXPECT_NE(std::string(e.what()).find("another user"), std::string::npos) << e.what();
    }
    struct stat st;
    EXPECT_EQ(stat(("/dev/shm" + name).c_str(), &st), 0) << "left alone";
    shm_unlink(name.c_str());
}

TEST(Comm, StaleRegionOfOurOwnIsReplaced)
{
    const std::string name = unique_name("stale");
    const int fd = shm_open(name.c_str(), O_RDWR | O_CREAT | O_EXCL, 0644);
    ASSERT_GE(fd, 0);
    close(fd);
    Comm c(name, "");
    c.init();
    navkit_rcomm_t *r = navkit_rcomm_open(name.c_str());
    EXPECT_STREQ(navkit_rcomm_error(r), "");
    navkit_rcomm_close(r);
}

TEST(Comm, ASecondHostIsRefusedWhileTheFirstRuns)
{
    const std::string name = unique_name("twohosts");
    Comm first(name, "");
    first.init();
    first.set_host_heartbeat(5);
    Comm second(name, "");
    try {
        second.init();
        FAIL() << "a second host took over a running one's region";
    } catch (const std::runtime_error &e) {
        const std::string w = e.what();
        EXPECT_NE(w.find("rcomm " + name + ": in use by a running navkit-host"), std::string::npos) << w;
        EXPECT_NE(w.find("--shm NAME"), std::string::npos) << w;
    }
    navkit_rcomm_t *r = navkit_rcomm_open(name.c_str());
    ASSERT_STREQ(navkit_rcomm_error(r), "") << "the first host's region is untouched";
    uint32_t hb = 0;
    EXPECT_EQ(navkit_rcomm_host_heartbeat(r, &hb), 0);
    EXPECT_EQ(hb, 5u);
    navkit_rcomm_close(r);
    first.shutdown();
    Comm third(name, "");
    third.init(); // the first has ended: the name is free again
}

TEST(Comm, ClientOwnerRules)
{
    const uid_t me = geteuid();
    const gid_t mine = getegid();
    EXPECT_EQ(navkit_rcomm_owner_check(me, 12345, 0600, nullptr, 0), 0) << "ours";
    EXPECT_EQ(navkit_rcomm_owner_check(me, mine, 0666, nullptr, 0), 1) << "world-writable: never";
    EXPECT_EQ(navkit_rcomm_owner_check(me + 1, mine, 0660, nullptr, 0), 0) << "another user's, shared with our group";
    EXPECT_EQ(navkit_rcomm_owner_check(me + 1, mine, 0600, nullptr, 0), 2)
        << "our group, but the mode does not share it";
    EXPECT_EQ(navkit_rcomm_owner_check(me + 1, mine + 54321, 0660, nullptr, 0), 2) << "a group that is not ours";
}

TEST(Comm, ClientOpensAnotherUsersRegionSharedWithItsGroup)
{
    if (geteuid() != 0) {
        GTEST_SKIP() << "needs root to make a region owned by another user";
    }
    const std::string name = unique_name("group");
    Comm c(name, "");
    c.init();
    const std::string path = "/dev/shm" + name;
    ASSERT_EQ(chown(path.c_str(), 65534, getegid()), 0);
    ASSERT_EQ(chmod(path.c_str(), 0660), 0);
    navkit_rcomm_t *r = navkit_rcomm_open(name.c_str());
    EXPECT_STREQ(navkit_rcomm_error(r), "");
    navkit_rcomm_close(r);
    ASSERT_EQ(chown(path.c_str(), 65534, 65534), 0);
    r = navkit_rcomm_open(name.c_str());
    EXPECT_NE(std::string(navkit_rcomm_error(r)).find("not ours"), std::string::npos)
        << "another user, a group not ours";
    navkit_rcomm_close(r);
    ASSERT_EQ(chown(path.c_str(), 0, 0), 0);
    ASSERT_EQ(chmod(path.c_str(), 0666), 0);
    r = navkit_rcomm_open(name.c_str());
    EXPECT_NE(std::string(navkit_rcomm_error(r)).find("world-writable"), std::string::npos) << navkit_rcomm_error(r);
    navkit_rcomm_close(r);
}

TEST(Comm, ShmGroupGivesTheGroupAndMode0660)
{
    // chgrp to a group the process is not in needs root (CAP_CHOWN)
    if (geteuid() != 0) {
        GTEST_SKIP() << "not root: fchown to another group needs CAP_CHOWN";
    }
    std::string name_of_group;
    gid_t gid = 0;
    setgrent();
    while (const group *g = getgrent()) {
        if (g->gr_gid != getegid()) { // a group the region would not get anyway
            name_of_group = g->gr_name;
            gid = g->gr_gid;
            break;
        }
    }
    endgrent();
    if (name_of_group.empty()) {
        GTEST_SKIP() << "no group other than ours (" << getegid() << ") in the group database";
    }
    const std::string name = unique_name("group");
    Comm c(name, name_of_group);
    c.init();
    struct stat st;
    ASSERT_EQ(stat(("/dev/shm" + name).c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0660u) << "owner and group read and write, nobody else";
    EXPECT_EQ(st.st_gid, gid) << "the region's group is " << name_of_group;
    EXPECT_EQ(st.st_uid, geteuid());
    c.shutdown();
}

TEST(Comm, ARegionOfAnotherUserIsNamedAsSuchToAUserWhoCannotOpenIt)
{
    // root opens any region (and sees its owner); an ordinary user gets EACCES from
    // shm_open, which must not end up as "File exists" from the O_EXCL create after it
    if (geteuid() != 0) {
        GTEST_SKIP() << "needs root to make a region owned by another user";
    }
    const std::string name = unique_name("foreign-user");
    const int fd = shm_open(name.c_str(), O_RDWR | O_CREAT | O_EXCL, 0600); // root's, 0600
    ASSERT_GE(fd, 0);
    close(fd);
    int p[2];
    ASSERT_EQ(pipe(p), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) { // as nobody: the message goes up the pipe
        close(p[0]);
        std::string said = "accepted";
        if (setgid(65534) != 0 || setuid(65534) != 0) {
            said = "setuid failed";
        } else {
            try {
                Comm c(name, "");
                c.init();
            } catch (const std::runtime_error &e) {
                said = e.what();
            }
        }
        (void)!write(p[1], said.data(), said.size());
        _exit(0);
    }
    close(p[1]);
    char buf[512];
    const ssize_t n = read(p[0], buf, sizeof buf);
    close(p[0]);
    waitpid(child, nullptr, 0);
    shm_unlink(name.c_str());
    ASSERT_GT(n, 0);
    EXPECT_EQ(std::string(buf, static_cast<size_t>(n)),
              "rcomm " + name + ": exists and belongs to another user (uid 0): refused");
}

TEST(Comm, ARegionCutShortIsLetGoNeverASigbus)
{
    const std::string name = unique_name("cut");
    struct Case {
        bool after_check; // cut after the frame's size check (the guard), else before it
        off_t to;         // the region's size after the cut, bytes
    };
    // before the frame's check: to 0 and to a size that keeps its page (only the size
    // check sees that one); after it: to 0, the page gone when it is touched (the guard)
    for (const Case k : {Case{false, 0}, Case{false, 100}, Case{true, 0}}) {
        Comm c(name, "");
        c.init();
        const int rfd = shm_open(name.c_str(), O_RDWR, 0);
        ASSERT_GE(rfd, 0);
        navkit_lisp_cmd_t cmd;
        navkit_lisp_data_t d;
        navkit_lisp_data_defaults(&d);
        EXPECT_TRUE(c.begin_frame());
        c.send_lisp_data(d);
        EXPECT_EQ(c.lost(), "");
        if (k.after_check) {
            EXPECT_TRUE(c.begin_frame());
            c.set_between_check_and_access([rfd, k] { (void)!ftruncate(rfd, k.to); });
        } else {
            ASSERT_EQ(ftruncate(rfd, k.to), 0);
            EXPECT_FALSE(c.begin_frame());
        }
        EXPECT_FALSE(c.read_lisp_cmd(&cmd));
        EXPECT_EQ(c.lost(), "rcomm " + name + ": the region was cut to " + std::to_string(k.to) +
                                " bytes by another process (" + std::to_string(NAVKIT_RCOMM_SIZE) +
                                " needed): refused, the planner is gone");
        sigset_t mask;
        ASSERT_EQ(sigprocmask(SIG_BLOCK, nullptr, &mask), 0);
        EXPECT_EQ(sigismember(&mask, SIGBUS), 0) << "the guard's jump leaves SIGBUS unblocked";
        EXPECT_FALSE(c.begin_frame()) << "a region let go stays let go";
        c.send_lisp_data(d);
        EXPECT_EQ(c.planner_heartbeat(), 0u) << "nothing is read after";
        close(rfd);
        c.shutdown();
        struct stat st;
        EXPECT_NE(stat(("/dev/shm" + name).c_str(), &st), 0) << "removed at shutdown all the same";
    }
}

TEST(Comm, AGuardedFaultIsCountedOnlyInsideTheRegion)
{
    // the guard is there for the region's accesses only: a SIGBUS sent by kill while a
    // region is mapped goes to the handler before it (here: a flag)
    static volatile sig_atomic_t seen = 0;
    struct sigaction sa, old;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = [](int) { seen = 1; };
    sigemptyset(&sa.sa_mask);
    ASSERT_EQ(sigaction(SIGBUS, &sa, &old), 0);
    const std::string name = unique_name("chain");
    Comm c(name, "");
    c.init();
    raise(SIGBUS);
    EXPECT_EQ(seen, 1);
    EXPECT_EQ(c.lost(), "");
    c.shutdown();
}

TEST(Comm, ThePlannerLibraryClosesARegionCutShort)
{
    const std::string name = unique_name("cut-client");
    Comm c(name, "");
    c.init();
    navkit_rcomm_t *r = navkit_rcomm_open(name.c_str());
    ASSERT_STREQ(navkit_rcomm_error(r), "");
    ASSERT_EQ(truncate(("/dev/shm" + name).c_str(), 0), 0);
    int32_t w[NAVKIT_LISP_DATA_WORDS];
    EXPECT_EQ(navkit_rcomm_read_data(r, w), -1) << "no SIGBUS: the size is checked first";
    EXPECT_EQ(std::string(navkit_rcomm_error(r)),
              "rcomm " + name + ": the region was cut to 0 bytes by another process (the layout needs " +
                  std::to_string(NAVKIT_RCOMM_SIZE) + "): closed");
    int32_t cmd[NAVKIT_LISP_CMD_WORDS] = {1};
    EXPECT_EQ(navkit_rcomm_write_cmd(r, cmd), -1) << "does nothing on a closed region";
    EXPECT_EQ(navkit_rcomm_heartbeat(r), -1);
    uint32_t hb = 7;
    EXPECT_EQ(navkit_rcomm_host_heartbeat(r, &hb), -1);
    EXPECT_EQ(hb, 7u) << "nothing read";
    navkit_rcomm_close(r);
}
