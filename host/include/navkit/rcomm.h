/* rcomm.h: the planner's end of navkit-host's shared memory, for planners in C or in
 * any language with a C FFI (docs/internals.md "rcomm shared memory", docs/host.md).
 *
 *   navkit_rcomm_t r;
 *   if (navkit_rcomm_open(&r, "/navkit") != 0) { ...r.error says why... }
 *   int32_t cmd[NAVKIT_LISP_CMD_WORDS] = {0};   cmd[0] = time_tag; cmd[2] = 1; ...
 *   navkit_rcomm_write_cmd(&r, cmd);             (bumps the heartbeat too)
 *   navkit_rcomm_heartbeat(&r);                  (at least once per host frame)
 *   int32_t data[NAVKIT_LISP_DATA_WORDS];
 *   if (navkit_rcomm_read_data(&r, data)) ...    (1 = a consistent copy)
 *   navkit_rcomm_close(&r);
 *
 * Words are the spec's raw int32 values in spec order (navkit_lisp_cmd_pack/unpack of
 * the generated navkit_proto.h convert to and from the structs). Header-only, POSIX +
 * GCC/Clang __atomic builtins; little-endian hosts (the region's byte order). Link -lrt
 * on old glibc. A region is opened when it is ours, or another user's shared with one of
 * our groups (group rw, the host's shm_group); never a world-writable one. Every
 * shared word is accessed with aligned 32-bit atomics; the seqlock
 * writer makes seq odd, writes, makes it even (+2 per message); the reader copies
 * between two equal, even reads of seq, retrying a bounded number of times.
 * Another process of the host's user can cut the region short (ftruncate): every access
 * first checks its size, and a region shorter than the layout is closed (r->base NULL,
 * r->error says so; reads return 0 and writes do nothing) instead of a SIGBUS. A cut in
 * the moment between that check and the access still raises SIGBUS: a planner that must
 * survive even that guards its accesses as navkit-host does (host/src/comm.cpp).
 */
#ifndef NAVKIT_RCOMM_H
#define NAVKIT_RCOMM_H

#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include "navkit/navkit_proto.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    uint8_t *base;     /* the mapped region, NULL when closed */
    int fd;            /* the region, kept for the size check of every access; -1 closed */
    char error[160];   /* why navkit_rcomm_open failed, or why the region was closed */
} navkit_rcomm_t;

static inline uint32_t *navkit_rcomm_word_(navkit_rcomm_t *r, size_t off)
{
    return (uint32_t *)(void *)(r->base + off);
}

/* May this client use a region of owner uid, group gid and mode? 0 = yes, else why not:
 * 1 = world-writable (never), 2 = neither ours nor shared with one of our groups
 * (owner another user: the region's group must be one of ours and its mode must give
 * that group read and write, as the host's shm_group = NAME makes it, mode 0660). */
static inline int navkit_rcomm_owner_check(uid_t uid, gid_t gid, mode_t mode)
{
    gid_t groups[256];
    int n, i;
    if (mode & S_IWOTH) {
        return 1;
    }
    if (uid == geteuid()) {
        return 0;
    }
    if ((mode & (S_IRGRP | S_IWGRP)) != (S_IRGRP | S_IWGRP)) {
        return 2;
    }
    if (gid == getegid()) {
        return 0;
    }
    n = getgroups((int)(sizeof groups / sizeof groups[0]), groups);
    for (i = 0; i < n; i++) {
        if (groups[i] == gid) {
            return 0;
        }
    }
    return 2;
}

/* Open the host's region `name`: 0, or -1 with r->error set (missing, world-writable,
 * neither ours nor shared with our group, too small, wrong magic, version or spec hash). */
static inline int navkit_rcomm_open(navkit_rcomm_t *r, const char *name)
{
    struct stat st;
    void *p;
    int fd, why;
    r->base = NULL;
    r->fd = -1;
    r->error[0] = '\0';
    fd = shm_open(name, O_RDWR, 0);
    if (fd < 0) {
        snprintf(r->error, sizeof r->error, "rcomm %s: cannot open", name);
        return -1;
    }
    if (fstat(fd, &st) != 0) {
        close(fd);
        snprintf(r->error, sizeof r->error, "rcomm %s: cannot stat", name);
        return -1;
    }
    why = navkit_rcomm_owner_check(st.st_uid, st.st_gid, st.st_mode);
    if (why != 0) {
        close(fd);
        if (why == 1) {
            snprintf(r->error, sizeof r->error, "rcomm %s: world-writable (mode %03o): refused", name,
                     (unsigned)(st.st_mode & 0777));
        } else {
            snprintf(r->error, sizeof r->error,
                     "rcomm %s: owned by uid %u, not us, and group %u is not ours with rw (mode %03o): refused",
                     name, (unsigned)st.st_uid, (unsigned)st.st_gid, (unsigned)(st.st_mode & 0777));
        }
        return -1;
    }
    if (st.st_size < (off_t)NAVKIT_RCOMM_SIZE) {
        close(fd);
        snprintf(r->error, sizeof r->error, "rcomm %s: too small: refused", name);
        return -1;
    }
    p = mmap(NULL, NAVKIT_RCOMM_SIZE, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (p == MAP_FAILED) {
        close(fd);
        snprintf(r->error, sizeof r->error, "rcomm %s: mmap failed", name);
        return -1;
    }
    r->base = (uint8_t *)p;
    r->fd = fd;
    if (__atomic_load_n(navkit_rcomm_word_(r, NAVKIT_RCOMM_MAGIC_OFFSET), __ATOMIC_ACQUIRE) != NAVKIT_RCOMM_MAGIC ||
        __atomic_load_n(navkit_rcomm_word_(r, NAVKIT_RCOMM_VERSION_OFFSET), __ATOMIC_RELAXED) != NAVKIT_RCOMM_VERSION ||
        __atomic_load_n(navkit_rcomm_word_(r, NAVKIT_RCOMM_SPEC_HASH_OFFSET), __ATOMIC_RELAXED) != NAVKIT_SPEC_HASH) {
        munmap(p, NAVKIT_RCOMM_SIZE);
        close(fd);
        r->base = NULL;
        r->fd = -1;
        snprintf(r->error, sizeof r->error, "rcomm %s: magic, version or spec hash differ", name);
        return -1;
    }
    return 0;
}

static inline void navkit_rcomm_close(navkit_rcomm_t *r)
{
    if (r->base) {  /* fd is the region's only while it is mapped */
        munmap(r->base, NAVKIT_RCOMM_SIZE);
        close(r->fd);
        r->base = NULL;
        r->fd = -1;
    }
}

/* 1 when the region is open and whole; else 0, and a region cut short by another
 * process is closed with r->error saying so (its next access would be a SIGBUS). */
static inline int navkit_rcomm_whole_(navkit_rcomm_t *r)
{
    struct stat st;
    st.st_size = -1;
    if (!r->base) {
        return 0;
    }
    if (fstat(r->fd, &st) == 0 && st.st_size >= (off_t)NAVKIT_RCOMM_SIZE) {
        return 1;
    }
    navkit_rcomm_close(r);
    snprintf(r->error, sizeof r->error, "rcomm: the region was cut to %lld bytes by another process (%u needed): closed",
             (long long)st.st_size, (unsigned)NAVKIT_RCOMM_SIZE);
    return 0;
}

/* Seqlock write of n words into the slot at byte offset slot. */
static inline void navkit_rcomm_write_slot_(navkit_rcomm_t *r, size_t slot, const int32_t *w, size_t n)
{
    uint32_t *seq = navkit_rcomm_word_(r, slot);
    uint32_t s = __atomic_load_n(seq, __ATOMIC_RELAXED);
    size_t i;
    s += s & 1u;
    __atomic_store_n(seq, s + 1u, __ATOMIC_RELAXED);
    __atomic_thread_fence(__ATOMIC_RELEASE);
    for (i = 0; i < n; i++) {
        __atomic_store_n(navkit_rcomm_word_(r, slot + NAVKIT_RCOMM_SLOT_WORDS_OFFSET + 4 * i), (uint32_t)w[i],
                         __ATOMIC_RELAXED);
    }
    __atomic_store_n(seq, s + 2u, __ATOMIC_RELEASE);
}

/* Seqlock read of n words: 1 = consistent copy in w, 0 = never written or still torn. */
static inline int navkit_rcomm_read_slot_(navkit_rcomm_t *r, size_t slot, int32_t *w, size_t n)
{
    uint32_t *seq = navkit_rcomm_word_(r, slot);
    int attempt;
    size_t i;
    for (attempt = 0; attempt < 1000; attempt++) {
        uint32_t s1 = __atomic_load_n(seq, __ATOMIC_ACQUIRE);
        if (s1 & 1u) {
            continue;
        }
        for (i = 0; i < n; i++) {
            w[i] = (int32_t)__atomic_load_n(navkit_rcomm_word_(r, slot + NAVKIT_RCOMM_SLOT_WORDS_OFFSET + 4 * i),
                                            __ATOMIC_RELAXED);
        }
        __atomic_thread_fence(__ATOMIC_ACQUIRE);
        if (__atomic_load_n(seq, __ATOMIC_RELAXED) == s1) {
            return s1 != 0u;
        }
    }
    return 0;
}

/* Bump the planner heartbeat (the host stops the robot after planner_timeout without it). */
static inline void navkit_rcomm_heartbeat(navkit_rcomm_t *r)
{
    if (!navkit_rcomm_whole_(r)) {
        return;
    }
    __atomic_fetch_add(navkit_rcomm_word_(r, NAVKIT_RCOMM_PLANNER_HEARTBEAT_OFFSET), 1u, __ATOMIC_RELEASE);
}

/* Write a whole lisp_cmd (a changed time tag, word 0, marks a new command) and beat. */
static inline void navkit_rcomm_write_cmd(navkit_rcomm_t *r, const int32_t words[NAVKIT_LISP_CMD_WORDS])
{
    if (!navkit_rcomm_whole_(r)) {
        return;
    }
    navkit_rcomm_write_slot_(r, NAVKIT_RCOMM_LISP_CMD_OFFSET, words, NAVKIT_LISP_CMD_WORDS);
    navkit_rcomm_heartbeat(r);
}

static inline void navkit_rcomm_write_emotion(navkit_rcomm_t *r, const int32_t words[NAVKIT_EMOTION_WORDS])
{
    if (!navkit_rcomm_whole_(r)) {
        return;
    }
    navkit_rcomm_write_slot_(r, NAVKIT_RCOMM_EMOTION_OFFSET, words, NAVKIT_EMOTION_WORDS);
}

/* The host's latest lisp_data: 1 = copied, 0 = none yet (or torn for every retry). */
static inline int navkit_rcomm_read_data(navkit_rcomm_t *r, int32_t words[NAVKIT_LISP_DATA_WORDS])
{
    if (!navkit_rcomm_whole_(r)) {
        return 0;
    }
    return navkit_rcomm_read_slot_(r, NAVKIT_RCOMM_LISP_DATA_OFFSET, words, NAVKIT_LISP_DATA_WORDS);
}

/* The host's frame counter. */
static inline uint32_t navkit_rcomm_host_heartbeat(navkit_rcomm_t *r)
{
    if (!navkit_rcomm_whole_(r)) {
        return 0;
    }
    return __atomic_load_n(navkit_rcomm_word_(r, NAVKIT_RCOMM_HOST_HEARTBEAT_OFFSET), __ATOMIC_ACQUIRE);
}

#ifdef __cplusplus
}
#endif
#endif /* NAVKIT_RCOMM_H */
