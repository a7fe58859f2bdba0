/* navkit_rcomm.c: libnavkit_rcomm.so (the contract is in navkit_rcomm.h). */
#define _POSIX_C_SOURCE 200809L
#include "navkit_rcomm.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "navkit/navkit_proto.h"
#include "navkit_rcomm_slot.h"

#define RCOMM_NAME_MAX 255 /* bytes of a shared-memory name after its "/" (NAME_MAX) */
#define RCOMM_ERROR_BYTES 320

struct navkit_rcomm {
    uint8_t *base; /* the mapping, NULL when not usable */
    int fd;        /* the region, kept for the size check of every access; -1 none */
    navkit_rcomm_layout_t layout;
    char name[RCOMM_NAME_MAX + 2]; /* "/" + name + NUL */
    char error[RCOMM_ERROR_BYTES]; /* "" while usable */
};

static const navkit_rcomm_layout_t rcomm_built = {
    NAVKIT_RCOMM_MAGIC,
    NAVKIT_RCOMM_VERSION,
    NAVKIT_SPEC_HASH,
    NAVKIT_RCOMM_SIZE,
    NAVKIT_RCOMM_MAGIC_OFFSET,
    NAVKIT_RCOMM_VERSION_OFFSET,
    NAVKIT_RCOMM_SPEC_HASH_OFFSET,
    NAVKIT_RCOMM_PLANNER_HEARTBEAT_OFFSET,
    NAVKIT_RCOMM_HOST_HEARTBEAT_OFFSET,
    NAVKIT_RCOMM_SLOT_WORDS_OFFSET,
    NAVKIT_RCOMM_LISP_CMD_OFFSET,
    NAVKIT_RCOMM_LISP_DATA_OFFSET,
    NAVKIT_RCOMM_EMOTION_OFFSET,
    NAVKIT_LISP_CMD_WORDS,
    NAVKIT_LISP_DATA_WORDS,
    NAVKIT_EMOTION_WORDS,
};

const navkit_rcomm_layout_t *navkit_rcomm_layout(void)
{
    return &rcomm_built;
}

/* printf into why (why_size bytes; NULL: nothing). */
static void rcomm_say(char *why, size_t why_size, const char *fmt, ...)
{
    va_list ap;
    if (!why || why_size == 0) {
        return;
    }
    va_start(ap, fmt);
    vsnprintf(why, why_size, fmt, ap);
    va_end(ap);
}

int navkit_rcomm_owner_check(uid_t uid, gid_t gid, mode_t mode, char *why, size_t why_size)
{
    gid_t groups[256];
    int n, i;
    rcomm_say(why, why_size, "%s", "");
    if (mode & S_IWOTH) {
        rcomm_say(why, why_size, "world-writable (mode %03o)", (unsigned)(mode & 0777));
        return 1;
    }
    if (uid == geteuid()) {
        return 0;
    }
    if ((mode & (S_IRGRP | S_IWGRP)) == (S_IRGRP | S_IWGRP)) {
        if (gid == getegid()) {
            return 0;
        }
        n = getgroups((int)(sizeof groups / sizeof groups[0]), groups);
        for (i = 0; i < n; i++) {
            if (groups[i] == gid) {
                return 0;
            }
        }
    }
    rcomm_say(why, why_size, "owned by uid %u, not us, and group %u is not ours with rw (mode %03o)", (unsigned)uid,
              (unsigned)gid, (unsigned)(mode & 0777));
    return 2;
}

int navkit_rcomm_name_check(const char *name, char *why, size_t why_size)
{
    const char *rest = name ? name + 1 : NULL;
    rcomm_say(why, why_size, "%s", "");
    if (!name || name[0] != '/' || !rest[0] || strchr(rest, '/') || !strcmp(rest, ".") || !strcmp(rest, "..") ||
        strlen(rest) > RCOMM_NAME_MAX) {
        rcomm_say(why, why_size,
                  "'%s' is not a POSIX shared-memory name ('/' then 1..%d characters, no other '/', not . or ..)",
                  name ? name : "(null)", RCOMM_NAME_MAX);
        return -1;
    }
    return 0;
}

/* Is every word of layout l inside its size and aligned? 0, or -1 with why. */
static int rcomm_layout_check(const navkit_rcomm_layout_t *l, char *why, size_t why_size)
{
    const uint32_t word[] = {l->magic_at, l->version_at, l->spec_hash_at, l->planner_heartbeat_at,
                             l->host_heartbeat_at};
    const uint32_t slot[] = {l->lisp_cmd_at, l->lisp_data_at, l->emotion_at};
    const uint32_t words[] = {l->lisp_cmd_words, l->lisp_data_words, l->emotion_words};
    size_t i;
    if (l->slot_words_at % 4u != 0) {
        rcomm_say(why, why_size, "layout: slot_words_at %u is not a multiple of 4", (unsigned)l->slot_words_at);
        return -1;
    }
    for (i = 0; i < sizeof word / sizeof word[0]; i++) {
        if (word[i] % 4u != 0 || (uint64_t)word[i] + 4u > l->size) {
            rcomm_say(why, why_size, "layout: header word at %u is not an aligned word of the %u bytes",
                      (unsigned)word[i], (unsigned)l->size);
            return -1;
        }
    }
    for (i = 0; i < sizeof slot / sizeof slot[0]; i++) {
        if (slot[i] % 4u != 0 || (uint64_t)slot[i] + l->slot_words_at + 4u * (uint64_t)words[i] > l->size ||
            (uint64_t)slot[i] + 4u > l->size) {
            rcomm_say(why, why_size, "layout: the slot at %u (%u words) is not aligned inside the %u bytes",
                      (unsigned)slot[i], (unsigned)words[i], (unsigned)l->size);
            return -1;
        }
    }
    return 0;
}

/* Let the mapping go (the handle stays, its error says why). */
static void rcomm_unmap(navkit_rcomm_t *r)
{
    if (r->base) {
        munmap(r->base, r->layout.size);
        r->base = NULL;
    }
    if (r->fd >= 0) {
        close(r->fd);
        r->fd = -1;
    }
}

static navkit_rcomm_t *rcomm_refuse(navkit_rcomm_t *r, const char *fmt, ...)
{
    va_list ap;
    int n;
    rcomm_unmap(r);
    n = snprintf(r->error, sizeof r->error, "rcomm %s: ", r->name);
    va_start(ap, fmt);
    vsnprintf(r->error + n, sizeof r->error - (size_t)n, fmt, ap);
    va_end(ap);
    return r;
}

navkit_rcomm_t *navkit_rcomm_open_layout(const char *name, const navkit_rcomm_layout_t *layout)
{
    char why[RCOMM_ERROR_BYTES - 64], path[RCOMM_NAME_MAX + 16];
    struct stat st;
    navkit_rcomm_t *r = (navkit_rcomm_t *)calloc(1, sizeof *r);
    void *p;
    uint32_t magic, version, spec;
    if (!r) {
        return NULL;
    }
    r->fd = -1;
    r->layout = *layout;
    if (navkit_rcomm_name_check(name, why, sizeof why) != 0) {
        snprintf(r->error, sizeof r->error, "rcomm %s", why);
        return r;
    }
    snprintf(r->name, sizeof r->name, "%s", name);
    if (rcomm_layout_check(layout, why, sizeof why) != 0) {
        return rcomm_refuse(r, "%s", why);
    }
    snprintf(path, sizeof path, "/dev/shm%s", name);
    r->fd = open(path, O_RDWR | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
    if (r->fd < 0) {
        if (errno == ELOOP) {
            return rcomm_refuse(r, "%s is a symbolic link: refused", path);
        }
        return rcomm_refuse(r, "%s", strerror(errno));
    }
    if (fstat(r->fd, &st) != 0) {
        return rcomm_refuse(r, "%s", strerror(errno));
    }
    if (!S_ISREG(st.st_mode)) {
        return rcomm_refuse(r, "%s is not a shared-memory region: refused", path);
    }
    if (navkit_rcomm_owner_check(st.st_uid, st.st_gid, st.st_mode, why, sizeof why) != 0) {
        return rcomm_refuse(r, "%s: refused", why);
    }
    if (st.st_size < (off_t)layout->size) {
        return rcomm_refuse(r, "%lld bytes, the layout needs %u", (long long)st.st_size, (unsigned)layout->size);
    }
    p = mmap(NULL, layout->size, PROT_READ | PROT_WRITE, MAP_SHARED, r->fd, 0);
    if (p == MAP_FAILED) {
        return rcomm_refuse(r, "mmap: %s", strerror(errno));
    }
    r->base = (uint8_t *)p;
    /* the host stores the magic last (release): a client that sees it sees the rest */
    magic = navkit_rcomm_load(r->base, layout->magic_at, __ATOMIC_ACQUIRE);
    version = navkit_rcomm_load(r->base, layout->version_at, __ATOMIC_RELAXED);
    spec = navkit_rcomm_load(r->base, layout->spec_hash_at, __ATOMIC_RELAXED);
    if (magic != layout->magic || version != layout->version) {
        return rcomm_refuse(r, "magic 0x%08X version %u, expected 0x%08X version %u", (unsigned)magic,
                            (unsigned)version, (unsigned)layout->magic, (unsigned)layout->version);
    }
    if (spec != layout->spec_hash) {
        return rcomm_refuse(r, "spec hash 0x%08X, ours 0x%08X", (unsigned)spec, (unsigned)layout->spec_hash);
    }
    return r;
}

navkit_rcomm_t *navkit_rcomm_open(const char *name)
{
    return navkit_rcomm_open_layout(name, &rcomm_built);
}

void navkit_rcomm_close(navkit_rcomm_t *r)
{
    if (r) {
        rcomm_unmap(r);
        free(r);
    }
}

const char *navkit_rcomm_error(const navkit_rcomm_t *r)
{
    return r ? r->error : "rcomm: no handle (out of memory)";
}

/* 0 when the region is mapped and whole; else -1, and a region cut short by another
 * process is let go with the error saying so (its next access would be a SIGBUS). */
static int rcomm_whole(navkit_rcomm_t *r)
{
    struct stat st;
    if (!r || !r->base) {
        return -1;
    }
    if (fstat(r->fd, &st) == 0 && st.st_size >= (off_t)r->layout.size) {
        return 0;
    }
    rcomm_refuse(r, "the region was cut to %lld bytes by another process (the layout needs %u): closed",
                 (long long)(fstat(r->fd, &st) == 0 ? st.st_size : -1), (unsigned)r->layout.size);
    return -1;
}

int navkit_rcomm_heartbeat(navkit_rcomm_t *r)
{
    if (rcomm_whole(r) != 0) {
        return -1;
    }
    navkit_rcomm_bump(r->base, r->layout.planner_heartbeat_at);
    return 0;
}

int navkit_rcomm_write_cmd(navkit_rcomm_t *r, const int32_t *words)
{
    if (rcomm_whole(r) != 0) {
        return -1;
    }
    navkit_rcomm_slot_write(r->base, r->layout.lisp_cmd_at, r->layout.slot_words_at, words, r->layout.lisp_cmd_words);
    navkit_rcomm_bump(r->base, r->layout.planner_heartbeat_at);
    return 0;
}

int navkit_rcomm_write_emotion(navkit_rcomm_t *r, const int32_t *words)
{
    if (rcomm_whole(r) != 0) {
        return -1;
    }
    navkit_rcomm_slot_write(r->base, r->layout.emotion_at, r->layout.slot_words_at, words, r->layout.emotion_words);
    return 0;
}

int navkit_rcomm_read_data(navkit_rcomm_t *r, int32_t *words)
{
    if (rcomm_whole(r) != 0) {
        return -1;
    }
    return navkit_rcomm_slot_read(r->base, r->layout.lisp_data_at, r->layout.slot_words_at, words,
                                  r->layout.lisp_data_words);
}

int navkit_rcomm_read_cmd(navkit_rcomm_t *r, int32_t *words)
{
    if (rcomm_whole(r) != 0) {
        return -1;
    }
    return navkit_rcomm_slot_read(r->base, r->layout.lisp_cmd_at, r->layout.slot_words_at, words,
                                  r->layout.lisp_cmd_words);
}

int navkit_rcomm_host_heartbeat(navkit_rcomm_t *r, uint32_t *out)
{
    if (rcomm_whole(r) != 0) {
        return -1;
    }
    *out = navkit_rcomm_load(r->base, r->layout.host_heartbeat_at, __ATOMIC_ACQUIRE);
    return 0;
}

int navkit_rcomm_planner_heartbeat(navkit_rcomm_t *r, uint32_t *out)
{
    if (rcomm_whole(r) != 0) {
        return -1;
    }
    *out = navkit_rcomm_load(r->base, r->layout.planner_heartbeat_at, __ATOMIC_ACQUIRE);
    return 0;
}
