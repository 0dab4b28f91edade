/* POSIX file operations for the output writer (module tmafm_posix binds to these).
 *
 * Fortran I/O cannot create a file exclusively without following symbolic links, cannot
 * fsync, and reports device and directory targets poorly, so the writer works on plain
 * file descriptors through these few functions.  Every function returns 0 (or a
 * non-negative result) on success and -errno on failure; none keeps any state.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define TMAFM_CLMUL 1
#endif

/* Kinds of path reported by tmafm_path_kind (mirrored in tmafm_posix.f90). */
enum { KIND_MISSING = 0, KIND_REGULAR = 1, KIND_DIRECTORY = 2, KIND_CHAR_DEVICE = 3,
       KIND_FIFO = 4, KIND_SYMLINK = 5, KIND_OTHER = 6 };

static int kind_of_mode(mode_t mode)
{
    if (S_ISREG(mode)) return KIND_REGULAR;
    if (S_ISDIR(mode)) return KIND_DIRECTORY;
    if (S_ISCHR(mode)) return KIND_CHAR_DEVICE;
    if (S_ISFIFO(mode)) return KIND_FIFO;
    if (S_ISLNK(mode)) return KIND_SYMLINK;
    return KIND_OTHER;
}

/* What `path` is, without following a final symbolic link; in *target the kind of what a
 * symbolic link points to (KIND_MISSING when dangling).  -errno if it cannot be told. */
int tmafm_path_kind(const char *path, int *target)
{
    struct stat st;
    *target = KIND_MISSING;
    if (lstat(path, &st) != 0) return errno == ENOENT ? KIND_MISSING : -errno;
    int kind = kind_of_mode(st.st_mode);
    if (kind == KIND_SYMLINK) {
        if (stat(path, &st) == 0) *target = kind_of_mode(st.st_mode);
        else if (errno != ENOENT) return -errno;
    } else {
        *target = kind;
    }
    return kind;
}

/* Create a new, empty file next to `final_path` under a unique name, exclusively
 * (O_CREAT|O_EXCL never follows a symbolic link and never reuses an existing name).
 * The name (NUL-terminated) goes to name_out[capacity].  Returns the descriptor. */
int tmafm_create_temporary(const char *final_path, char *name_out, int capacity)
{
    static const char alphabet[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
    const char *slash = strrchr(final_path, '/');
    size_t dir_len = slash ? (size_t)(slash - final_path) + 1 : 0;
    size_t base_len = strlen(final_path) - dir_len;
    /* Keep the name within NAME_MAX (255): the base is cut to 200 bytes. */
    if (base_len > 200) base_len = 200;
    for (int attempt = 0; attempt < 100; ++attempt) {
        unsigned char noise[10];
        char suffix[sizeof noise + 1];
        if (getrandom(noise, sizeof noise, 0) != (ssize_t)sizeof noise) return -EIO;
        for (size_t i = 0; i < sizeof noise; ++i) suffix[i] = alphabet[noise[i] % 62];
        suffix[sizeof noise] = '\0';
        /* "dir/.base.partial-XXXXXXXXXX": hidden, in the target's folder (so rename is atomic). */
        int n = snprintf(name_out, (size_t)capacity, "%.*s.%.*s.partial-%s", (int)dir_len,
                         final_path, (int)base_len, final_path + dir_len, suffix);
        if (n < 0 || n >= capacity) return -ENAMETOOLONG;
        int fd = open(name_out, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
        if (fd >= 0) return fd;
        if (errno != EEXIST) return -errno;
    }
    return -EEXIST;
}

/* Open an existing character device or FIFO for writing, as it is (no truncation). */
int tmafm_open_device(const char *path)
{
    int fd = open(path, O_WRONLY | O_NOCTTY | O_CLOEXEC);
    return fd >= 0 ? fd : -errno;
}

/* Open a character device or FIFO for writing without waiting: a FIFO with no reader is
 * not waited for but reported, *no_reader = 1 (ENXIO), so that the caller can say it will
 * wait before it calls tmafm_open_device.  The descriptor returned blocks as usual. */
int tmafm_open_device_now(const char *path, int *no_reader)
{
    *no_reader = 0;
    int fd = open(path, O_WRONLY | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) {
        if (errno == ENXIO) *no_reader = 1;
        return -errno;
    }
    int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) {
        int code = errno;
        close(fd);
        return -code;
    }
    return fd;
}

/* Open an input file for reading (its bytes are then read with tmafm_read_some). */
int tmafm_open_input(const char *path)
{
    int fd = open(path, O_RDONLY | O_NOCTTY | O_CLOEXEC);
    return fd >= 0 ? fd : -errno;
}

/* Open a FIFO (or a pipe, through /dev/stdin or /dev/fd/N) for reading without waiting for a
 * writer, and wait at most wait_ms milliseconds for its first bytes (or for a writer to come
 * and go): *ready = 1 if something is there to read, 0 if nothing came.  Returns the
 * descriptor, non-blocking until tmafm_wait_input. */
int tmafm_open_fifo_reader(const char *path, int wait_ms, int *ready)
{
    *ready = 0;
    int fd = open(path, O_RDONLY | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) return -errno;
    struct pollfd pfd = {fd, POLLIN, 0};
    int n;
    do n = poll(&pfd, 1, wait_ms); while (n < 0 && errno == EINTR);
    if (n < 0) {
        int code = errno;
        close(fd);
        return -code;
    }
    *ready = n > 0;
    return fd;
}

/* Wait (without a limit) until the FIFO opened by tmafm_open_fifo_reader has bytes to read or
 * its writer closed it, then make its reads blocking: they end at the writers' close. */
int tmafm_wait_input(int fd)
{
    struct pollfd pfd = {fd, POLLIN, 0};
    int n;
    do n = poll(&pfd, 1, -1); while (n < 0 && errno == EINTR);
    if (n < 0) return -errno;
    int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) return -errno;
    return 0;
}

/* read(2) of at most n bytes, resumed after interruptions: the count read (0 at the end). */
int64_t tmafm_read_some(int fd, void *buf, int64_t n)
{
    ssize_t done;
    do done = read(fd, buf, (size_t)n); while (done < 0 && errno == EINTR);
    return done < 0 ? -errno : (int64_t)done;
}

/* 0 if fd is open for writing. */
int tmafm_check_descriptor(int fd)
{
    int flags = fcntl(fd, F_GETFL);
    if (flags < 0) return -errno;
    return (flags & O_ACCMODE) == O_RDONLY ? -EBADF : 0;
}

/* Write all n bytes of buf, resuming after partial writes and interruptions. */
int tmafm_write_all(int fd, const void *buf, int64_t n)
{
    const char *p = buf;
    while (n > 0) {
        ssize_t chunk = n > (1 << 30) ? (1 << 30) : (ssize_t)n;
        ssize_t done = write(fd, p, (size_t)chunk);
        if (done < 0) {
            if (errno == EINTR) continue;
            return -errno;
        }
        p += done;
        n -= done;
    }
    return 0;
}

/* Flush fd to the storage device.  Devices and pipes that cannot sync are not an error. */
int tmafm_sync(int fd)
{
    if (fsync(fd) == 0 || errno == EINVAL || errno == EROFS) return 0;
    return -errno;
}

/* Map the pages under buf[0..n) now, in one call, instead of one page fault per page at
 * the first write (MADV_POPULATE_WRITE, Linux 5.14).  Only a hint: where the kernel lacks it
 * nothing happens and the pages are mapped on first touch as usual. */
void tmafm_prefault(void *buf, int64_t n)
{
#ifdef MADV_POPULATE_WRITE
    uintptr_t page = (uintptr_t)sysconf(_SC_PAGESIZE);
    uintptr_t start = (uintptr_t)buf & ~(page - 1);
    if (n > 0) (void)madvise((void *)start, (uintptr_t)buf + (uintptr_t)n - start, MADV_POPULATE_WRITE);
#else
    (void)buf;
    (void)n;
#endif
}

/* close(2); an error here can mean the data never reached the disk (NFS, quotas). */
int tmafm_close(int fd)
{
    if (close(fd) == 0 || errno == EINTR) return 0;
    return -errno;
}

int tmafm_rename(const char *old_path, const char *new_path)
{
    return rename(old_path, new_path) == 0 ? 0 : -errno;
}

int tmafm_unlink(const char *path)
{
    return unlink(path) == 0 ? 0 : -errno;
}

/* 0 if the existing file `path` may be written by this user. */
int tmafm_check_writable(const char *path)
{
    return access(path, W_OK) == 0 ? 0 : -errno;
}

/* 1 if `a` and `b` name the same existing file (same device and inode, links followed), 0 if
 * not or if either cannot be stat'ed. */
int tmafm_same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (stat(a, &sa) != 0 || stat(b, &sb) != 0) return 0;
    return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

/* The text of an error number (positive errno) into buf[capacity], NUL-terminated.  strerror_r
   (GNU form: _GNU_SOURCE above), not strerror, whose buffer for unknown codes is shared. */
void tmafm_error_text(int code, char *buf, int capacity)
{
    if (capacity <= 0) return;
    char own[256];
    const char *text = strerror_r(code, own, sizeof own);
    snprintf(buf, (size_t)capacity, "%s", text);
}

/* The ZIP CRC-32 (polynomial 0xEDB88320) tables for slicing by 8, into table[8][256].  The
   Fortran side holds them as integer(c_int32_t): int32_t here too (one type on both sides for
   LTO), read as uint32_t (signed and unsigned variants of a type may alias). */
void tmafm_crc32_table(int32_t *table_out)
{
    uint32_t *table = (uint32_t *)table_out;
    for (uint32_t i = 0; i < 256; ++i) {
        uint32_t c = i;
        for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        table[i] = c;
    }
    for (int s = 1; s < 8; ++s)
        for (int i = 0; i < 256; ++i)
            table[256 * s + i] = (table[256 * (s - 1) + i] >> 8) ^ table[table[256 * (s - 1) + i] & 0xFFu];
}

#ifdef TMAFM_CLMUL
/* CRC-32 by carry-less multiplication (Intel, "Fast CRC Computation for Generic Polynomials
 * Using PCLMULQDQ", 2009; the folding constants of the reflected polynomial 0xEDB88320, as in
 * Linux's crc32-pclmul and Chromium's zlib).  `state` is the inverted running CRC; n is a
 * multiple of 16 and at least 64.  Returns the new state. */
__attribute__((target("pclmul,sse4.1")))
static uint32_t crc32_clmul(const unsigned char *buf, int64_t n, uint32_t state)
{
    const __m128i k1k2 = _mm_set_epi64x(0x01c6e41596LL, 0x0154442bd4LL);
    const __m128i k3k4 = _mm_set_epi64x(0x00ccaa009eLL, 0x01751997d0LL);
    const __m128i k5k0 = _mm_set_epi64x(0, 0x0163cd6124LL);
    const __m128i poly = _mm_set_epi64x(0x01f7011641LL, 0x01db710641LL);
    const __m128i low32 = _mm_setr_epi32(~0, 0, ~0, 0);
    __m128i x0, x1, x2, x3, x4, x5, x6, x7, x8;

    x1 = _mm_xor_si128(_mm_loadu_si128((const __m128i *)buf), _mm_cvtsi32_si128((int)state));
    x2 = _mm_loadu_si128((const __m128i *)(buf + 16));
    x3 = _mm_loadu_si128((const __m128i *)(buf + 32));
    x4 = _mm_loadu_si128((const __m128i *)(buf + 48));
    buf += 64;
    n -= 64;
    x0 = k1k2;
    while (n >= 64) { /* fold four 128-bit lanes by 512 bits */
        x5 = _mm_clmulepi64_si128(x1, x0, 0x00);
        x6 = _mm_clmulepi64_si128(x2, x0, 0x00);
        x7 = _mm_clmulepi64_si128(x3, x0, 0x00);
        x8 = _mm_clmulepi64_si128(x4, x0, 0x00);
        x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, x0, 0x11), x5),
                           _mm_loadu_si128((const __m128i *)buf));
        x2 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x2, x0, 0x11), x6),
                           _mm_loadu_si128((const __m128i *)(buf + 16)));
        x3 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x3, x0, 0x11), x7),
                           _mm_loadu_si128((const __m128i *)(buf + 32)));
        x4 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x4, x0, 0x11), x8),
                           _mm_loadu_si128((const __m128i *)(buf + 48)));
        buf += 64;
        n -= 64;
    }
    x0 = k3k4; /* fold the four lanes into one */
    x5 = _mm_clmulepi64_si128(x1, x0, 0x00);
    x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, x0, 0x11), x2), x5);
    x5 = _mm_clmulepi64_si128(x1, x0, 0x00);
    x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, x0, 0x11), x3), x5);
    x5 = _mm_clmulepi64_si128(x1, x0, 0x00);
    x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, x0, 0x11), x4), x5);
    while (n >= 16) { /* remaining 16-byte blocks */
        x5 = _mm_clmulepi64_si128(x1, x0, 0x00);
        x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, x0, 0x11),
                                         _mm_loadu_si128((const __m128i *)buf)), x5);
        buf += 16;
        n -= 16;
    }
    /* 128 -> 64 bits */
    x2 = _mm_clmulepi64_si128(x1, x0, 0x10);
    x1 = _mm_xor_si128(_mm_srli_si128(x1, 8), x2);
    x0 = k5k0;
    x2 = _mm_srli_si128(x1, 4);
    x1 = _mm_xor_si128(_mm_clmulepi64_si128(_mm_and_si128(x1, low32), x0, 0x00), x2);
    /* Barrett reduction to 32 bits */
    x0 = poly;
    x2 = _mm_and_si128(_mm_clmulepi64_si128(_mm_and_si128(x1, low32), x0, 0x10), low32);
    x2 = _mm_clmulepi64_si128(x2, x0, 0x00);
    x1 = _mm_xor_si128(x1, x2);
    return (uint32_t)_mm_extract_epi32(x1, 1);
}
#endif

/* Continue a CRC-32 over n bytes: crc = 0 to start; the result is the CRC so far (as int32_t,
   the Fortran integer(c_int32_t); the bits are those of the uint32_t CRC). */
int32_t tmafm_crc32_update(const int32_t *table_in, int32_t crc_in, const void *buf, int64_t n)
{
    const uint32_t *table = (const uint32_t *)table_in;
    const unsigned char *p = buf;
    uint32_t crc = ~(uint32_t)crc_in;
#ifdef TMAFM_CLMUL
    if (n >= 64 && __builtin_cpu_supports("pclmul") && __builtin_cpu_supports("sse4.1")) {
        int64_t chunk = n & ~(int64_t)15;
        crc = crc32_clmul(p, chunk, crc);
        p += chunk;
        n -= chunk;
    }
#endif
    while (n >= 8) {
        uint32_t lo, hi;
        memcpy(&lo, p, 4);
        memcpy(&hi, p + 4, 4);
#if __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
        lo = __builtin_bswap32(lo);
        hi = __builtin_bswap32(hi);
#endif
        lo ^= crc;
        crc = table[7 * 256 + (lo & 0xFFu)] ^ table[6 * 256 + ((lo >> 8) & 0xFFu)] ^
              table[5 * 256 + ((lo >> 16) & 0xFFu)] ^ table[4 * 256 + (lo >> 24)] ^
              table[3 * 256 + (hi & 0xFFu)] ^ table[2 * 256 + ((hi >> 8) & 0xFFu)] ^
              table[1 * 256 + ((hi >> 16) & 0xFFu)] ^ table[hi >> 24];
        p += 8;
        n -= 8;
    }
    while (n-- > 0) crc = table[(crc ^ *p++) & 0xFFu] ^ (crc >> 8);
    return (int32_t)~crc;
}

/* tmafm_crc32_update over characters: its own name, so that the Fortran interface with a
   character buffer does not redeclare tmafm_crc32_update with another type. */
int32_t tmafm_crc32_text(const int32_t *table, int32_t crc, const char *buf, int64_t n)
{
    return tmafm_crc32_update(table, crc, buf, n);
}
