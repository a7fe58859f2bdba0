/* navkit_rcomm_slot.h: the shared words of navkit-host's rcomm region, for both of its
 * ends: the planner library (src/navkit_rcomm.c) and navkit-host (host/src/comm.cpp).
 * Not part of libnavkit_rcomm.so's ABI (docs/internals.md "rcomm shared memory").
 *
 * Contract: every shared word is one aligned uint32 (the layout's offsets are multiples
 * of 4), accessed with GCC/Clang __atomic builtins and stored little-endian (the
 * region's byte order, on any host). A slot is a seqlock: a uint32 seq at +0, the
 * message's int32 words at +words_at. The writer makes seq odd, writes the words, makes
 * it even (+2 per message); the reader copies between two equal, even reads of seq and
 * retries a bounded number of times. seq 0 means never written.
 */
#ifndef NAVKIT_RCOMM_SLOT_H
#define NAVKIT_RCOMM_SLOT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Reads of a slot before it gives up on a writer that keeps it changing (or died odd). */
#define NAVKIT_RCOMM_SLOT_RETRIES 1000

/* The region's little-endian word from a native one, and back (the same swap). */
static inline uint32_t navkit_rcomm_le(uint32_t v)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    return __builtin_bswap32(v);
#else
    return v;
#endif
}

/* The shared word at byte offset off of the mapped region base. */
static inline uint32_t *navkit_rcomm_word(uint8_t *base, size_t off)
{
    return (uint32_t *)(void *)(base + off);
}

/* Atomic load of the word at off (order: an __ATOMIC_* constant), native value. */
static inline uint32_t navkit_rcomm_load(uint8_t *base, size_t off, int order)
{
    return navkit_rcomm_le(__atomic_load_n(navkit_rcomm_word(base, off), order));
}

/* Atomic store of native value v into the word at off. */
static inline void navkit_rcomm_store(uint8_t *base, size_t off, uint32_t v, int order)
{
    __atomic_store_n(navkit_rcomm_word(base, off), navkit_rcomm_le(v), order);
}

/* Atomic read-modify-write: the word at off += 1 (no beat of another writer is lost). */
static inline void navkit_rcomm_bump(uint8_t *base, size_t off)
{
    uint32_t *w = navkit_rcomm_word(base, off);
    uint32_t old = __atomic_load_n(w, __ATOMIC_RELAXED);
    while (!__atomic_compare_exchange_n(w, &old, navkit_rcomm_le(navkit_rcomm_le(old) + 1u), 1, __ATOMIC_RELEASE,
                                        __ATOMIC_RELAXED)) {
    }
}

/* Seqlock write of n int32 words w into the slot at byte offset slot (words at
 * slot + words_at). A writer that died mid-write left seq odd: the next one skips it. */
static inline void navkit_rcomm_slot_write(uint8_t *base, size_t slot, size_t words_at, const int32_t *w, size_t n)
{
    uint32_t s = navkit_rcomm_load(base, slot, __ATOMIC_RELAXED);
    size_t i;
    s += s & 1u;
    navkit_rcomm_store(base, slot, s + 1u, __ATOMIC_RELAXED);
    __atomic_thread_fence(__ATOMIC_RELEASE);
    for (i = 0; i < n; i++) {
        navkit_rcomm_store(base, slot + words_at + 4u * i, (uint32_t)w[i], __ATOMIC_RELAXED);
    }
    navkit_rcomm_store(base, slot, s + 2u, __ATOMIC_RELEASE);
}

/* Seqlock read of n int32 words into w: 1 = a consistent copy, 0 = never written or a
 * write in progress for every retry (w then holds no message). */
static inline int navkit_rcomm_slot_read(uint8_t *base, size_t slot, size_t words_at, int32_t *w, size_t n)
{
    int attempt;
    size_t i;
    for (attempt = 0; attempt < NAVKIT_RCOMM_SLOT_RETRIES; attempt++) {
        const uint32_t s1 = navkit_rcomm_load(base, slot, __ATOMIC_ACQUIRE);
        if (s1 & 1u) {
            continue;
        }
        for (i = 0; i < n; i++) {
            w[i] = (int32_t)navkit_rcomm_load(base, slot + words_at + 4u * i, __ATOMIC_RELAXED);
        }
        __atomic_thread_fence(__ATOMIC_ACQUIRE);
        if (navkit_rcomm_load(base, slot, __ATOMIC_RELAXED) == s1) {
            return s1 != 0u;
        }
    }
    return 0;
}

#ifdef __cplusplus
}
#endif
#endif /* NAVKIT_RCOMM_SLOT_H */
