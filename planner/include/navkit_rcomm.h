/* navkit_rcomm.h: libnavkit_rcomm.so, the planner's end of navkit-host's rcomm shared
 * memory, for planners in C or in any language with a C FFI (Python's navkit.rcomm is
 * a ctypes wrapper over it). docs/internals.md "rcomm shared memory", docs/host.md.
 *
 *   navkit_rcomm_t *r = navkit_rcomm_open("/navkit");
 *   if (!r || navkit_rcomm_error(r)[0]) { ...the text says why...; navkit_rcomm_close(r); }
 *   int32_t cmd[NAVKIT_LISP_CMD_WORDS] = {0};  cmd[0] = time_tag; ...
 *   navkit_rcomm_write_cmd(r, cmd);            (bumps the heartbeat too)
 *   navkit_rcomm_heartbeat(r);                 (at least once per host frame)
 *   int32_t data[NAVKIT_LISP_DATA_WORDS];
 *   if (navkit_rcomm_read_data(r, data) == 1) ...
 *   navkit_rcomm_close(r);
 *
 * Words are the spec's raw int32 values in spec order (navkit_lisp_cmd_pack/unpack of the
 * generated navkit_proto.h convert to and from the structs; NAVKIT_*_WORDS give their
 * counts). Functions returning int: -1 = the region is not usable (navkit_rcomm_error
 * says why), else as documented. The ABI is these functions, the opaque handle and
 * navkit_rcomm_layout_t, nothing else (the library exports no other symbol).
 *
 * Rules the library keeps: the name is a POSIX shared-memory name as the host takes it
 * ("/" then 1..255 bytes, no other "/", not "." or ".."); the region /dev/shm/NAME is
 * opened without following a symbolic link and must be a regular file; it is used when
 * it is ours, or another user's shared with one of our groups (group rw, the host's
 * shm_group, mode 0660), never a world-writable one; its magic, layout version and spec
 * hash must be the layout's. Another process of the host's user can cut the region
 * short (ftruncate): every access first checks its size, and a region shorter than the
 * layout is closed (the error says so, every later call returns -1) instead of a SIGBUS.
 * A cut in the moment between that check and the access still raises SIGBUS: a planner
 * that must survive even that guards its accesses as navkit-host does (host/src/comm.cpp).
 * Linux (the region lives in /dev/shm). Not thread-safe per handle: one handle per thread.
 */
#ifndef NAVKIT_RCOMM_H
#define NAVKIT_RCOMM_H

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__)
#define NAVKIT_RCOMM_API __attribute__((visibility("default")))
#else
#define NAVKIT_RCOMM_API
#endif

/* An open region (opaque). */
typedef struct navkit_rcomm navkit_rcomm_t;

/* Where the region keeps what: byte offsets of uint32 words and slots, all multiples of
 * 4, and the values its header must hold. navkit_rcomm_layout() gives the one of the spec
 * the library was built from (the generated navkit_proto.h); a client that reads the spec
 * itself may pass its own to navkit_rcomm_open_layout. */
typedef struct {
    uint32_t magic, version, spec_hash; /* the header's expected values */
    uint32_t size;                      /* the whole region, bytes */
    uint32_t magic_at, version_at, spec_hash_at, planner_heartbeat_at, host_heartbeat_at; /* bytes */
    uint32_t slot_words_at;                                  /* a slot's words after its seq (at +0), bytes */
    uint32_t lisp_cmd_at, lisp_data_at, emotion_at;          /* slots, bytes */
    uint32_t lisp_cmd_words, lisp_data_words, emotion_words; /* int32 words per message */
} navkit_rcomm_layout_t;

/* The layout of the spec this library was built from. */
NAVKIT_RCOMM_API const navkit_rcomm_layout_t *navkit_rcomm_layout(void);

/* Open region `name` laid out as navkit_rcomm_layout(). Returns a handle (NULL only when
 * memory is short): navkit_rcomm_error() is "" when it is open, else why not (missing,
 * a bad name, a link, refused by the owner rule, too small, magic, version or spec hash
 * differ). Close every handle, open or not, with navkit_rcomm_close. */
NAVKIT_RCOMM_API navkit_rcomm_t *navkit_rcomm_open(const char *name);

/* navkit_rcomm_open with another layout (checked: every word inside its size). */
NAVKIT_RCOMM_API navkit_rcomm_t *navkit_rcomm_open_layout(const char *name, const navkit_rcomm_layout_t *layout);

/* Unmap and free the handle (NULL: nothing). The host owns the region and removes it. */
NAVKIT_RCOMM_API void navkit_rcomm_close(navkit_rcomm_t *r);

/* "" while the region is usable; else one line saying why it is not (NUL-terminated,
 * valid until navkit_rcomm_close). */
NAVKIT_RCOMM_API const char *navkit_rcomm_error(const navkit_rcomm_t *r);

/* Write one whole lisp_cmd (layout.lisp_cmd_words words; a changed time tag, word 0,
 * marks a new command for the host) and bump the heartbeat: 0, or -1. */
NAVKIT_RCOMM_API int navkit_rcomm_write_cmd(navkit_rcomm_t *r, const int32_t *words);

/* Write one whole emotion message (layout.emotion_words words): 0, or -1. */
NAVKIT_RCOMM_API int navkit_rcomm_write_emotion(navkit_rcomm_t *r, const int32_t *words);

/* The host's latest lisp_data (layout.lisp_data_words words): 1 = copied, 0 = none yet
 * (or a write in progress for every bounded retry), -1 = not usable. */
NAVKIT_RCOMM_API int navkit_rcomm_read_data(navkit_rcomm_t *r, int32_t *words);

/* The lisp_cmd in the region now (what the host reads next): 1, 0 or -1 as read_data. */
NAVKIT_RCOMM_API int navkit_rcomm_read_cmd(navkit_rcomm_t *r, int32_t *words);

/* Bump the planner heartbeat word (atomic read-modify-write; the host stops the robot
 * when it stays unchanged for planner_timeout s): 0, or -1. */
NAVKIT_RCOMM_API int navkit_rcomm_heartbeat(navkit_rcomm_t *r);

/* The host's frame counter (+1 per host frame) into *out: 0, or -1. */
NAVKIT_RCOMM_API int navkit_rcomm_host_heartbeat(navkit_rcomm_t *r, uint32_t *out);

/* The planner heartbeat word as it is (every client's beats) into *out: 0, or -1. */
NAVKIT_RCOMM_API int navkit_rcomm_planner_heartbeat(navkit_rcomm_t *r, uint32_t *out);

/* May a client use a region of owner uid, group gid and mode (st_mode)? 0 = yes;
 * 1 = world-writable (never); 2 = neither ours nor shared with one of our groups with
 * read and write. why (why_size bytes, may be NULL) gets the reason, "" for 0. */
NAVKIT_RCOMM_API int navkit_rcomm_owner_check(uid_t uid, gid_t gid, mode_t mode, char *why, size_t why_size);

/* Is name a POSIX shared-memory name as the host takes it? 0 = yes, -1 = no (why, as
 * for owner_check, says so). */
NAVKIT_RCOMM_API int navkit_rcomm_name_check(const char *name, char *why, size_t why_size);

#ifdef __cplusplus
}
#endif
#endif /* NAVKIT_RCOMM_H */
