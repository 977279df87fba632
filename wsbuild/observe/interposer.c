/* wsbuild's observer: a library loaded into every process of a build step (LD_PRELOAD) that
 * writes down what the process read, listed, probed, ran and asked the environment for.
 *
 * It is inactive unless WSOBSERVE_DIR names a directory (or wsobserve_set_dir() is called):
 * each process then appends lines to WSOBSERVE_DIR/<pid>.log, one per distinct event:
 *   I <exe>        this image started (written first by every observed image)
 *   A <argv>       its arguments, separated by \x1f
 *   R <path>       a file opened for reading (a shared object loaded counts)
 *   W <path>       a file opened for writing, or made, renamed, linked or removed
 *   S <path>       a path looked at that exists (stat, access, readlink, realpath)
 *   N <path>       a path looked for that does not exist (a failed open, stat or access)
 *   D <path>       a directory listed (opendir, scandir), every time
 *   T <path>       a tree walked (fts_open, nftw, ftw): every directory below it listed
 *   G <pattern>    a glob(3) pattern expanded
 *   E <name>       an environment variable read (getenv, secure_getenv, setlocale, tzset)
 *   C <locale>     the locale setlocale chose from the environment (its files are read)
 *   X <path>       about to exec this program in this process
 *   F <path>       that exec failed (the process goes on)
 *   Y <pid> <path> a child spawned to run this program (posix_spawn)
 * Paths are absolute (relative ones resolved against the working directory or the directory
 * descriptor), newlines and backslashes escaped. An X not followed by F nor by the I of the
 * new image means the new image was not observed (a static binary, a setuid program, an
 * environment without LD_PRELOAD): wsbuild then holds the step as not fully observed.
 *
 * Its own files are written with raw system calls, and getenv is answered from `environ`
 * directly, so that nothing here needs the next library's symbols before it asked for them.
 */
#define _GNU_SOURCE
#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <fts.h>
#include <glob.h>
#include <grp.h>
#include <netdb.h>
#include <pwd.h>
#include <time.h>
#include <limits.h>
#include <link.h>
#include <locale.h>
#include <pthread.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/types.h>
#include <unistd.h>

extern char **environ;

#define EXPORT __attribute__((visibility("default")))

static char log_dir[PATH_MAX];
static int active = 0;
static int log_fd = -1;
static pid_t log_pid = 0;
static volatile int lock_word = 0;
static __thread int in_hook = 0;

/* ------------------------------------------------------------------------ the dedupe table */

#define TABLE_BITS 16
static uint64_t *table = NULL;
static size_t table_size = 0, table_used = 0;

static uint64_t hash_event(char kind, const char *text) {
    uint64_t h = 1469598103934665603ULL ^ (uint64_t)(unsigned char)kind;
    h *= 1099511628211ULL;
    for (const unsigned char *p = (const unsigned char *)text; *p; p++) {
        h ^= *p;
        h *= 1099511628211ULL;
    }
    return h ? h : 1;
}

static void *raw_map(size_t bytes) {
    void *p = (void *)syscall(SYS_mmap, NULL, bytes, 3 /* READ|WRITE */, 0x22 /* PRIVATE|ANON */,
                              -1, 0);
    return p == (void *)-1 ? NULL : p;
}

/* whether the event is new to this process (and remember it); under the lock */
static int first_time(char kind, const char *text) {
    uint64_t h = hash_event(kind, text);
    if (table == NULL || table_used * 2 >= table_size) {
        size_t size = table_size ? table_size * 2 : ((size_t)1 << TABLE_BITS);
        uint64_t *bigger = raw_map(size * sizeof(uint64_t));
        if (bigger == NULL)
            return 1;
        for (size_t i = 0; i < table_size; i++) {
            uint64_t v = table[i];
            if (!v)
                continue;
            size_t j = v & (size - 1);
            while (bigger[j])
                j = (j + 1) & (size - 1);
            bigger[j] = v;
        }
        if (table)
            syscall(SYS_munmap, table, table_size * sizeof(uint64_t));
        table = bigger;
        table_size = size;
    }
    size_t i = h & (table_size - 1);
    while (table[i]) {
        if (table[i] == h)
            return 0;
        i = (i + 1) & (table_size - 1);
    }
    table[i] = h;
    table_used++;
    return 1;
}

static void lock(void) {
    while (__atomic_exchange_n(&lock_word, 1, __ATOMIC_ACQUIRE))
        while (__atomic_load_n(&lock_word, __ATOMIC_RELAXED))
            ;
}

static void unlock(void) { __atomic_store_n(&lock_word, 0, __ATOMIC_RELEASE); }

/* ----------------------------------------------------------------------------- the log */

static size_t text_length(const char *s) {
    size_t n = 0;
    while (s[n])
        n++;
    return n;
}

static const char *env_value(const char *name) {
    size_t n = text_length(name);
    if (environ == NULL)
        return NULL;
    for (char **e = environ; *e; e++) {
        if (strncmp(*e, name, n) == 0 && (*e)[n] == '=')
            return *e + n + 1;
    }
    return NULL;
}

static void write_all(int fd, const char *data, size_t length) {
    while (length) {
        long done = syscall(SYS_write, fd, data, length);
        if (done <= 0) {
            if (done < 0 && errno == EINTR)
                continue;
            return;
        }
        data += done;
        length -= (size_t)done;
    }
}

/* the log of this process, opened again after a fork */
static int current_log(void) {
    pid_t pid = (pid_t)syscall(SYS_getpid);
    if (log_fd >= 0 && log_pid == pid)
        return log_fd;
    if (log_fd >= 0 && log_pid != pid) {
        /* a forked child: its own file; the parent's events stay the parent's */
        syscall(SYS_close, log_fd);
        log_fd = -1;
    }
    char path[PATH_MAX + 32];
    int n = snprintf(path, sizeof path, "%s/%d.log", log_dir, (int)pid);
    if (n <= 0 || (size_t)n >= sizeof path)
        return -1;
    log_fd = (int)syscall(SYS_openat, AT_FDCWD, path,
                          O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0600);
    log_pid = pid;
    return log_fd;
}

/* one line: kind, a space, the text escaped (\n and \\), a newline */
static void write_line(int fd, char kind, const char *text) {
    char buffer[2 * PATH_MAX + 8];
    size_t at = 0;
    buffer[at++] = kind;
    buffer[at++] = ' ';
    for (const char *p = text; *p; p++) {
        if (at + 4 >= sizeof buffer) {
            write_all(fd, buffer, at);
            at = 0;
        }
        if (*p == '\n') {
            buffer[at++] = '\\';
            buffer[at++] = 'n';
        } else if (*p == '\\') {
            buffer[at++] = '\\';
            buffer[at++] = '\\';
        } else {
            buffer[at++] = *p;
        }
    }
    buffer[at++] = '\n';
    write_all(fd, buffer, at);
}

/* A line written without the lock, the table or the cached descriptor: what the exec family
 * writes, which may run in a vfork child sharing its parent's memory (and its lock, held by
 * another of the parent's threads). */
static void emit_direct(char kind, const char *text) {
    if (!active || text == NULL)
        return;
    int saved = errno;
    char path[PATH_MAX + 32];
    int n = snprintf(path, sizeof path, "%s/%d.log", log_dir, (int)syscall(SYS_getpid));
    if (n > 0 && (size_t)n < sizeof path) {
        int fd = (int)syscall(SYS_openat, AT_FDCWD, path,
                              O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0600);
        if (fd >= 0) {
            write_line(fd, kind, text);
            syscall(SYS_close, fd);
        }
    }
    errno = saved;
}

static void emit(char kind, const char *text, int dedupe) {
    if (!active || text == NULL || in_hook)
        return;
    int saved = errno;
    in_hook = 1;
    lock();
    if (!dedupe || first_time(kind, text)) {
        int fd = current_log();
        if (fd >= 0)
            write_line(fd, kind, text);
    }
    unlock();
    in_hook = 0;
    errno = saved;
}

/* `p` as the caller passed it, null or not: the C library declares most of the functions
 * wrapped here with nonnull arguments, and the compiler then drops a wrapper's null check
 * (-fno-delete-null-pointer-checks does not stop it); programs probe with null (Rust's
 * standard library calls statx(0, NULL, 0, STATX_ALL, NULL) to learn whether it exists) */
static inline const char *opaque(const char *p) {
    __asm__("" : "+r"(p));
    return p;
}

static int given(const char *path) {
    path = opaque(path);
    return path != NULL && path[0] != 0;
}

/* `path` made absolute against the working directory, or the directory `dirfd` names */
static int absolute(int dirfd, const char *path, char *out, size_t size) {
    path = opaque(path);
    if (path == NULL)
        return 0;
    if (path[0] == '/') {
        size_t n = text_length(path);
        if (n >= size)
            return 0;
        memcpy(out, path, n + 1);
        return 1;
    }
    char base[PATH_MAX];
    long n;
    if (dirfd == AT_FDCWD) {
        n = syscall(SYS_getcwd, base, sizeof base);
        if (n <= 0)
            return 0;
        n = (long)text_length(base);
    } else {
        char link[64];
        snprintf(link, sizeof link, "/proc/self/fd/%d", dirfd);
        n = syscall(SYS_readlinkat, AT_FDCWD, link, base, sizeof base - 1);
        if (n <= 0)
            return 0;
        base[n] = 0;
    }
    if (path[0] == 0) { /* AT_EMPTY_PATH: the descriptor itself */
        if ((size_t)n >= size)
            return 0;
        memcpy(out, base, (size_t)n + 1);
        return 1;
    }
    if (path[0] == '.' && path[1] == 0) {
        if ((size_t)n >= size)
            return 0;
        memcpy(out, base, (size_t)n + 1);
        return 1;
    }
    if (path[0] == '.' && path[1] == '/')
        path += 2;
    int written = snprintf(out, size, "%s/%s", strcmp(base, "/") == 0 ? "" : base, path);
    return written > 0 && (size_t)written < size;
}

static void note_path(char kind, int dirfd, const char *path) {
    if (!active || in_hook || path == NULL)
        return;
    char full[PATH_MAX];
    if (absolute(dirfd, path, full, sizeof full))
        emit(kind, full, 1);
}

/* after a call that looked for `path`: S when it is there, N when it is not */
static void note_probe(int result, int dirfd, const char *path) {
    if (result == 0)
        note_path('S', dirfd, path);
    else if (errno == ENOENT || errno == ENOTDIR)
        note_path('N', dirfd, path);
}

static void note_open(int fd, int dirfd, const char *path, int flags) {
    if (fd >= 0)
        note_path((flags & (O_WRONLY | O_RDWR | O_CREAT | O_TRUNC)) ? 'W' : 'R', dirfd, path);
    else if (errno == ENOENT || errno == ENOTDIR)
        note_path('N', dirfd, path);
}

/* Python's import system lists a directory to look names up in it: its hook says so with
 * WSOBSERVE_QUIET set meanwhile, and writes the names it looked up instead (K lines) */
static int quiet(void) { return env_value("WSOBSERVE_QUIET") != NULL; }

/* a listing: written each time (not deduplicated), so that the Python hook's K, Q and P
 * lines can tell the import system's listings from the program's own by their order */
static void note_listing(int dirfd, const char *path) {
    if (!active || in_hook || path == NULL || quiet())
        return;
    char full[PATH_MAX];
    if (absolute(dirfd, path, full, sizeof full))
        emit('D', full, 0);
}

static void note_fd_listing(int fd) { note_listing(fd, ""); }

/* a file the C library reads on its own (its configuration), when it is there */
static void note_if_there(const char *path) {
    if (active && syscall(SYS_faccessat, AT_FDCWD, path, F_OK) == 0)
        emit('R', path, 1);
}

static int note_loaded(struct dl_phdr_info *info, size_t size, void *data) {
    (void)size;
    (void)data;
    if (info->dlpi_name && info->dlpi_name[0] == '/')
        emit('R', info->dlpi_name, 1);
    return 0;
}

/* ------------------------------------------------------------------------------- start */

static void start_logging(void) {
    char exe[PATH_MAX];
    long n = syscall(SYS_readlinkat, AT_FDCWD, "/proc/self/exe", exe, sizeof exe - 1);
    exe[n > 0 ? n : 0] = 0;
    emit('I', exe, 0);
    int fd = (int)syscall(SYS_openat, AT_FDCWD, "/proc/self/cmdline", O_RDONLY | O_CLOEXEC);
    if (fd >= 0) {
        char args[8192];
        long got = syscall(SYS_read, fd, args, sizeof args - 1);
        syscall(SYS_close, fd);
        if (got > 0) {
            for (long i = 0; i < got - 1; i++)
                if (args[i] == 0)
                    args[i] = '\x1f';
            args[got] = 0;
            emit('A', args, 0);
        }
    }
    emit('R', exe, 1);
    dl_iterate_phdr(note_loaded, NULL);
    note_if_there("/etc/ld.so.cache"); /* read by the dynamic loader before this library */
}

/* At exit: the libraries loaded, as the loader named them, and the files mapped into the
 * process, which the C library may have loaded on its own (the name service's and iconv's
 * modules, the locale archive), unseen by the dlopen wrapper. The maps are read in pieces: a
 * process with many libraries has more than any fixed buffer holds. */
static void note_mapped(char *line) {
    char *path = strchr(line, '/');
    if (path && !strstr(path, " (deleted)"))
        emit('R', path, 1);
}

__attribute__((destructor)) static void wsobserve_fini(void) {
    if (!active)
        return;
    dl_iterate_phdr(note_loaded, NULL);
    int fd = (int)syscall(SYS_openat, AT_FDCWD, "/proc/self/maps", O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return;
    static char maps[1 << 16];
    size_t held = 0;
    for (;;) {
        long got = syscall(SYS_read, fd, maps + held, sizeof maps - 1 - held);
        if (got <= 0)
            break;
        held += (size_t)got;
        maps[held] = 0;
        char *line = maps;
        for (char *end; (end = strchr(line, '\n')) != NULL; line = end + 1) {
            *end = 0;
            note_mapped(line);
        }
        held = (size_t)(maps + held - line);
        memmove(maps, line, held);
        if (held == sizeof maps - 1) /* a line longer than the buffer: not a path */
            held = 0;
    }
    syscall(SYS_close, fd);
    if (held) {
        maps[held] = 0;
        note_mapped(maps);
    }
}

static void fork_prepare(void) { lock(); }
static void fork_done(void) { unlock(); }

__attribute__((constructor)) static void wsobserve_init(void) {
    pthread_atfork(fork_prepare, fork_done, fork_done);
    if (quiet()) /* inherited from a thread's import while this process was started */
        unsetenv("WSOBSERVE_QUIET");
    const char *dir = env_value("WSOBSERVE_DIR");
    if (dir == NULL || dir[0] != '/' || text_length(dir) >= sizeof log_dir - 32)
        return;
    memcpy(log_dir, dir, text_length(dir) + 1);
    active = 1;
    start_logging();
}

/* Start observing this process from now on, into `dir` (a warm helper that runs one request
 * per forked child calls it in the child); NULL or "" stops. */
EXPORT void wsobserve_set_dir(const char *dir) {
    lock();
    if (log_fd >= 0)
        syscall(SYS_close, log_fd);
    log_fd = -1;
    if (table)
        syscall(SYS_munmap, table, table_size * sizeof(uint64_t));
    table = NULL;
    table_size = table_used = 0;
    unlock();
    if (dir == NULL || dir[0] != '/' || text_length(dir) >= sizeof log_dir - 32) {
        active = 0;
        return;
    }
    memcpy(log_dir, dir, text_length(dir) + 1);
    active = 1;
    start_logging();
}

/* ---------------------------------------------------------------------- the next symbols */

/* the next definition of `name`: its default version, else the first one (a symbol the C
 * library keeps for old binaries only, such as __xstat since 2.33) */
static void *next_symbol(const char *name) {
    void *found = dlsym(RTLD_NEXT, name);
#if defined(__x86_64__)
    if (!found)
        found = dlvsym(RTLD_NEXT, name, "GLIBC_2.2.5");
#elif defined(__aarch64__)
    if (!found)
        found = dlvsym(RTLD_NEXT, name, "GLIBC_2.17");
#endif
    return found;
}

#define REAL(name) \
    static __typeof__(name) *real_##name; \
    if (!real_##name) real_##name = (__typeof__(name) *)next_symbol(#name)

static int open_mode_flags(int flags) { return (flags & O_CREAT) || (flags & O_TMPFILE) == O_TMPFILE; }

EXPORT int open(const char *path, int flags, ...) {
    mode_t mode = 0;
    if (open_mode_flags(flags)) {
        va_list ap;
        va_start(ap, flags);
        mode = va_arg(ap, mode_t);
        va_end(ap);
    }
    REAL(open);
    int fd = real_open(path, flags, mode);
    note_open(fd, AT_FDCWD, path, flags);
    return fd;
}

EXPORT int open64(const char *path, int flags, ...) {
    mode_t mode = 0;
    if (open_mode_flags(flags)) {
        va_list ap;
        va_start(ap, flags);
        mode = va_arg(ap, mode_t);
        va_end(ap);
    }
    REAL(open64);
    int fd = real_open64(path, flags, mode);
    note_open(fd, AT_FDCWD, path, flags);
    return fd;
}

EXPORT int openat(int dirfd, const char *path, int flags, ...) {
    mode_t mode = 0;
    if (open_mode_flags(flags)) {
        va_list ap;
        va_start(ap, flags);
        mode = va_arg(ap, mode_t);
        va_end(ap);
    }
    REAL(openat);
    int fd = real_openat(dirfd, path, flags, mode);
    note_open(fd, dirfd, path, flags);
    return fd;
}

EXPORT int openat64(int dirfd, const char *path, int flags, ...) {
    mode_t mode = 0;
    if (open_mode_flags(flags)) {
        va_list ap;
        va_start(ap, flags);
        mode = va_arg(ap, mode_t);
        va_end(ap);
    }
    REAL(openat64);
    int fd = real_openat64(dirfd, path, flags, mode);
    note_open(fd, dirfd, path, flags);
    return fd;
}

int __open_2(const char *path, int flags);
int __open64_2(const char *path, int flags);
int __openat_2(int dirfd, const char *path, int flags);
int __openat64_2(int dirfd, const char *path, int flags);

EXPORT int __open_2(const char *path, int flags) {
    REAL(__open_2);
    int fd = real___open_2(path, flags);
    note_open(fd, AT_FDCWD, path, flags);
    return fd;
}

EXPORT int __open64_2(const char *path, int flags) {
    REAL(__open64_2);
    int fd = real___open64_2(path, flags);
    note_open(fd, AT_FDCWD, path, flags);
    return fd;
}

EXPORT int __openat_2(int dirfd, const char *path, int flags) {
    REAL(__openat_2);
    int fd = real___openat_2(dirfd, path, flags);
    note_open(fd, dirfd, path, flags);
    return fd;
}

EXPORT int __openat64_2(int dirfd, const char *path, int flags) {
    REAL(__openat64_2);
    int fd = real___openat64_2(dirfd, path, flags);
    note_open(fd, dirfd, path, flags);
    return fd;
}

EXPORT int creat(const char *path, mode_t mode) {
    REAL(creat);
    int fd = real_creat(path, mode);
    note_open(fd, AT_FDCWD, path, O_CREAT);
    return fd;
}

EXPORT int creat64(const char *path, mode_t mode) {
    REAL(creat64);
    int fd = real_creat64(path, mode);
    note_open(fd, AT_FDCWD, path, O_CREAT);
    return fd;
}

static int fopen_flags(const char *mode) {
    if (mode == NULL)
        return 0;
    if (mode[0] == 'r' && strchr(mode, '+') == NULL)
        return O_RDONLY;
    return O_WRONLY;
}

EXPORT FILE *fopen(const char *path, const char *mode) {
    REAL(fopen);
    FILE *f = real_fopen(path, mode);
    note_open(f ? 0 : -1, AT_FDCWD, path, fopen_flags(mode));
    return f;
}

EXPORT FILE *fopen64(const char *path, const char *mode) {
    REAL(fopen64);
    FILE *f = real_fopen64(path, mode);
    note_open(f ? 0 : -1, AT_FDCWD, path, fopen_flags(mode));
    return f;
}

EXPORT FILE *freopen(const char *path, const char *mode, FILE *stream) {
    REAL(freopen);
    FILE *f = real_freopen(path, mode, stream);
    if (opaque(path))
        note_open(f ? 0 : -1, AT_FDCWD, path, fopen_flags(mode));
    return f;
}

EXPORT FILE *freopen64(const char *path, const char *mode, FILE *stream) {
    REAL(freopen64);
    FILE *f = real_freopen64(path, mode, stream);
    if (opaque(path))
        note_open(f ? 0 : -1, AT_FDCWD, path, fopen_flags(mode));
    return f;
}

/* --------------------------------------------------------------------------- looking at */

EXPORT int stat(const char *path, struct stat *buf) {
    REAL(stat);
    int r = real_stat(path, buf);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int lstat(const char *path, struct stat *buf) {
    REAL(lstat);
    int r = real_lstat(path, buf);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int stat64(const char *path, struct stat64 *buf) {
    REAL(stat64);
    int r = real_stat64(path, buf);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int lstat64(const char *path, struct stat64 *buf) {
    REAL(lstat64);
    int r = real_lstat64(path, buf);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int fstatat(int dirfd, const char *path, struct stat *buf, int flags) {
    REAL(fstatat);
    int r = real_fstatat(dirfd, path, buf, flags);
    if (given(path))
        note_probe(r, dirfd, path);
    return r;
}

EXPORT int fstatat64(int dirfd, const char *path, struct stat64 *buf, int flags) {
    REAL(fstatat64);
    int r = real_fstatat64(dirfd, path, buf, flags);
    if (given(path))
        note_probe(r, dirfd, path);
    return r;
}

struct statx;
int statx(int dirfd, const char *path, int flags, unsigned int mask, struct statx *buf);
EXPORT int statx(int dirfd, const char *path, int flags, unsigned int mask, struct statx *buf) {
    REAL(statx);
    int r = real_statx(dirfd, path, flags, mask, buf);
    if (given(path))
        note_probe(r, dirfd, path);
    return r;
}

/* the entry points of binaries built against a C library before 2.33 */
int __xstat(int ver, const char *path, struct stat *buf);
int __lxstat(int ver, const char *path, struct stat *buf);
int __xstat64(int ver, const char *path, struct stat64 *buf);
int __lxstat64(int ver, const char *path, struct stat64 *buf);
int __fxstatat(int ver, int dirfd, const char *path, struct stat *buf, int flags);
int __fxstatat64(int ver, int dirfd, const char *path, struct stat64 *buf, int flags);

EXPORT int __xstat(int ver, const char *path, struct stat *buf) {
    REAL(__xstat);
    int r = real___xstat(ver, path, buf);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int __lxstat(int ver, const char *path, struct stat *buf) {
    REAL(__lxstat);
    int r = real___lxstat(ver, path, buf);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int __xstat64(int ver, const char *path, struct stat64 *buf) {
    REAL(__xstat64);
    int r = real___xstat64(ver, path, buf);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int __lxstat64(int ver, const char *path, struct stat64 *buf) {
    REAL(__lxstat64);
    int r = real___lxstat64(ver, path, buf);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int __fxstatat(int ver, int dirfd, const char *path, struct stat *buf, int flags) {
    REAL(__fxstatat);
    int r = real___fxstatat(ver, dirfd, path, buf, flags);
    if (given(path))
        note_probe(r, dirfd, path);
    return r;
}

EXPORT int __fxstatat64(int ver, int dirfd, const char *path, struct stat64 *buf, int flags) {
    REAL(__fxstatat64);
    int r = real___fxstatat64(ver, dirfd, path, buf, flags);
    if (given(path))
        note_probe(r, dirfd, path);
    return r;
}

EXPORT int access(const char *path, int mode) {
    REAL(access);
    int r = real_access(path, mode);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int faccessat(int dirfd, const char *path, int mode, int flags) {
    REAL(faccessat);
    int r = real_faccessat(dirfd, path, mode, flags);
    note_probe(r, dirfd, path);
    return r;
}

EXPORT int euidaccess(const char *path, int mode) {
    REAL(euidaccess);
    int r = real_euidaccess(path, mode);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT int eaccess(const char *path, int mode) {
    REAL(eaccess);
    int r = real_eaccess(path, mode);
    note_probe(r, AT_FDCWD, path);
    return r;
}

EXPORT ssize_t readlink(const char *path, char *buf, size_t size) {
    REAL(readlink);
    ssize_t r = real_readlink(path, buf, size);
    if (r >= 0 || errno == ENOENT || errno == ENOTDIR || errno == EINVAL)
        note_probe(r >= 0 || errno == EINVAL ? 0 : -1, AT_FDCWD, path);
    return r;
}

EXPORT ssize_t readlinkat(int dirfd, const char *path, char *buf, size_t size) {
    REAL(readlinkat);
    ssize_t r = real_readlinkat(dirfd, path, buf, size);
    if (r >= 0 || errno == ENOENT || errno == ENOTDIR || errno == EINVAL)
        note_probe(r >= 0 || errno == EINVAL ? 0 : -1, dirfd, path);
    return r;
}

EXPORT char *realpath(const char *path, char *resolved) {
    REAL(realpath);
    char *r = real_realpath(path, resolved);
    note_probe(r ? 0 : -1, AT_FDCWD, path);
    return r;
}

EXPORT char *canonicalize_file_name(const char *path) {
    REAL(canonicalize_file_name);
    char *r = real_canonicalize_file_name(path);
    note_probe(r ? 0 : -1, AT_FDCWD, path);
    return r;
}

/* ------------------------------------------------------------------------------ listing */

EXPORT DIR *opendir(const char *path) {
    REAL(opendir);
    DIR *d = real_opendir(path);
    if (d)
        note_listing(AT_FDCWD, path);
    else if (errno == ENOENT || errno == ENOTDIR)
        note_path('N', AT_FDCWD, path);
    return d;
}

EXPORT DIR *fdopendir(int fd) {
    REAL(fdopendir);
    DIR *d = real_fdopendir(fd);
    if (d && active && !in_hook)
        note_fd_listing(fd);
    return d;
}

EXPORT int scandir(const char *path, struct dirent ***list,
                   int (*filter)(const struct dirent *),
                   int (*compare)(const struct dirent **, const struct dirent **)) {
    REAL(scandir);
    int r = real_scandir(path, list, filter, compare);
    if (r >= 0)
        note_listing(AT_FDCWD, path);
    else if (errno == ENOENT || errno == ENOTDIR)
        note_path('N', AT_FDCWD, path);
    return r;
}

EXPORT int scandir64(const char *path, struct dirent64 ***list,
                     int (*filter)(const struct dirent64 *),
                     int (*compare)(const struct dirent64 **, const struct dirent64 **)) {
    REAL(scandir64);
    int r = real_scandir64(path, list, filter, compare);
    if (r >= 0)
        note_listing(AT_FDCWD, path);
    else if (errno == ENOENT || errno == ENOTDIR)
        note_path('N', AT_FDCWD, path);
    return r;
}

EXPORT int scandirat(int dirfd, const char *path, struct dirent ***list,
                     int (*filter)(const struct dirent *),
                     int (*compare)(const struct dirent **, const struct dirent **)) {
    REAL(scandirat);
    int r = real_scandirat(dirfd, path, list, filter, compare);
    if (r >= 0)
        note_listing(dirfd, path);
    return r;
}

EXPORT int glob(const char *pattern, int flags, int (*errfunc)(const char *, int), glob_t *found) {
    REAL(glob);
    note_path('G', AT_FDCWD, pattern);
    return real_glob(pattern, flags, errfunc, found);
}

EXPORT int glob64(const char *pattern, int flags, int (*errfunc)(const char *, int),
                  glob64_t *found) {
    REAL(glob64);
    note_path('G', AT_FDCWD, pattern);
    return real_glob64(pattern, flags, errfunc, found);
}

EXPORT FTS *fts_open(char *const *paths, int options,
                     int (*compare)(const FTSENT **, const FTSENT **)) {
    REAL(fts_open);
    for (char *const *p = paths; p && *p; p++)
        note_path('T', AT_FDCWD, *p);
    return real_fts_open(paths, options, compare);
}

EXPORT int nftw(const char *path, int (*fn)(const char *, const struct stat *, int, struct FTW *),
                int depth, int flags) {
    REAL(nftw);
    note_path('T', AT_FDCWD, path);
    return real_nftw(path, fn, depth, flags);
}

EXPORT int nftw64(const char *path,
                  int (*fn)(const char *, const struct stat64 *, int, struct FTW *), int depth,
                  int flags) {
    REAL(nftw64);
    note_path('T', AT_FDCWD, path);
    return real_nftw64(path, fn, depth, flags);
}

EXPORT int ftw(const char *path, int (*fn)(const char *, const struct stat *, int), int depth) {
    REAL(ftw);
    note_path('T', AT_FDCWD, path);
    return real_ftw(path, fn, depth);
}

/* ------------------------------------------------------------------------- making paths */
/* What a step makes is its output, never its input: a temporary file (mkstemp opens it inside
 * the C library, unseen by open's wrapper), a directory, a link, a rename's target. */

static void note_made(int ok, int dirfd, const char *path) {
    if (ok)
        note_path('W', dirfd, path);
}

EXPORT int mkstemp(char *template) {
    REAL(mkstemp);
    int fd = real_mkstemp(template);
    note_made(fd >= 0, AT_FDCWD, template);
    return fd;
}

EXPORT int mkstemp64(char *template) {
    REAL(mkstemp64);
    int fd = real_mkstemp64(template);
    note_made(fd >= 0, AT_FDCWD, template);
    return fd;
}

EXPORT int mkostemp(char *template, int flags) {
    REAL(mkostemp);
    int fd = real_mkostemp(template, flags);
    note_made(fd >= 0, AT_FDCWD, template);
    return fd;
}

EXPORT int mkostemp64(char *template, int flags) {
    REAL(mkostemp64);
    int fd = real_mkostemp64(template, flags);
    note_made(fd >= 0, AT_FDCWD, template);
    return fd;
}

EXPORT int mkstemps(char *template, int suffixlen) {
    REAL(mkstemps);
    int fd = real_mkstemps(template, suffixlen);
    note_made(fd >= 0, AT_FDCWD, template);
    return fd;
}

EXPORT int mkstemps64(char *template, int suffixlen) {
    REAL(mkstemps64);
    int fd = real_mkstemps64(template, suffixlen);
    note_made(fd >= 0, AT_FDCWD, template);
    return fd;
}

EXPORT int mkostemps(char *template, int suffixlen, int flags) {
    REAL(mkostemps);
    int fd = real_mkostemps(template, suffixlen, flags);
    note_made(fd >= 0, AT_FDCWD, template);
    return fd;
}

EXPORT int mkostemps64(char *template, int suffixlen, int flags) {
    REAL(mkostemps64);
    int fd = real_mkostemps64(template, suffixlen, flags);
    note_made(fd >= 0, AT_FDCWD, template);
    return fd;
}

EXPORT char *mkdtemp(char *template) {
    REAL(mkdtemp);
    char *made = real_mkdtemp(template);
    note_made(made != NULL, AT_FDCWD, template);
    return made;
}

EXPORT int mkdir(const char *path, mode_t mode) {
    REAL(mkdir);
    int r = real_mkdir(path, mode);
    note_made(r == 0, AT_FDCWD, path);
    return r;
}

EXPORT int mkdirat(int dirfd, const char *path, mode_t mode) {
    REAL(mkdirat);
    int r = real_mkdirat(dirfd, path, mode);
    note_made(r == 0, dirfd, path);
    return r;
}

EXPORT int rename(const char *from, const char *to) {
    REAL(rename);
    int r = real_rename(from, to);
    note_made(r == 0, AT_FDCWD, to);
    note_made(r == 0, AT_FDCWD, from);
    return r;
}

EXPORT int renameat(int fromfd, const char *from, int tofd, const char *to) {
    REAL(renameat);
    int r = real_renameat(fromfd, from, tofd, to);
    note_made(r == 0, tofd, to);
    note_made(r == 0, fromfd, from);
    return r;
}

EXPORT int renameat2(int fromfd, const char *from, int tofd, const char *to, unsigned flags) {
    REAL(renameat2);
    int r = real_renameat2(fromfd, from, tofd, to, flags);
    note_made(r == 0, tofd, to);
    note_made(r == 0, fromfd, from);
    return r;
}

EXPORT int symlink(const char *target, const char *path) {
    REAL(symlink);
    int r = real_symlink(target, path);
    note_made(r == 0, AT_FDCWD, path);
    return r;
}

EXPORT int symlinkat(const char *target, int dirfd, const char *path) {
    REAL(symlinkat);
    int r = real_symlinkat(target, dirfd, path);
    note_made(r == 0, dirfd, path);
    return r;
}

EXPORT int link(const char *from, const char *to) {
    REAL(link);
    int r = real_link(from, to);
    note_made(r == 0, AT_FDCWD, to);
    return r;
}

EXPORT int linkat(int fromfd, const char *from, int tofd, const char *to, int flags) {
    REAL(linkat);
    int r = real_linkat(fromfd, from, tofd, to, flags);
    note_made(r == 0, tofd, to);
    return r;
}

EXPORT int unlink(const char *path) {
    REAL(unlink);
    int r = real_unlink(path);
    note_made(r == 0, AT_FDCWD, path);
    return r;
}

EXPORT int unlinkat(int dirfd, const char *path, int flags) {
    REAL(unlinkat);
    int r = real_unlinkat(dirfd, path, flags);
    note_made(r == 0, dirfd, path);
    return r;
}

EXPORT int rmdir(const char *path) {
    REAL(rmdir);
    int r = real_rmdir(path);
    note_made(r == 0, AT_FDCWD, path);
    return r;
}

/* ---------------------------------------------------------------------------- running */

static void note_exec(const char *path) {
    char full[PATH_MAX];
    if (active && absolute(AT_FDCWD, path, full, sizeof full))
        emit_direct('X', full);
}

static void note_exec_failed(const char *path) {
    char full[PATH_MAX];
    if (active && absolute(AT_FDCWD, path, full, sizeof full))
        emit_direct('F', full);
}

/* where execvp would find `file`: each candidate on PATH looked at (S or N); `direct`: in
 * what may be a vfork child (emit_direct) */
static void note_search(const char *file, char *found, size_t size, int direct) {
    found[0] = 0;
    if (file == NULL || strchr(file, '/')) {
        if (file)
            snprintf(found, size, "%s", file);
        return;
    }
    const char *path = env_value("PATH");
    if (path == NULL)
        path = "/bin:/usr/bin";
    if (direct)
        emit_direct('E', "PATH");
    else
        emit('E', "PATH", 1);
    while (*path) {
        const char *end = strchr(path, ':');
        size_t n = end ? (size_t)(end - path) : text_length(path);
        char candidate[PATH_MAX], full[PATH_MAX];
        int written = snprintf(candidate, sizeof candidate, "%.*s/%s", (int)(n ? n : 1),
                               n ? path : ".", file);
        if (written > 0 && (size_t)written < sizeof candidate &&
            absolute(AT_FDCWD, candidate, full, sizeof full)) {
            int there = syscall(SYS_faccessat, AT_FDCWD, full, X_OK) == 0;
            if (direct)
                emit_direct(there ? 'S' : 'N', full);
            else
                emit(there ? 'S' : 'N', full, 1);
            if (there) {
                snprintf(found, size, "%s", full);
                return;
            }
        }
        if (!end)
            break;
        path = end + 1;
    }
}

EXPORT int execve(const char *path, char *const argv[], char *const envp[]) {
    REAL(execve);
    note_exec(path);
    int r = real_execve(path, argv, envp);
    note_exec_failed(path);
    return r;
}

EXPORT int execv(const char *path, char *const argv[]) {
    REAL(execv);
    note_exec(path);
    int r = real_execv(path, argv);
    note_exec_failed(path);
    return r;
}

EXPORT int execvpe(const char *file, char *const argv[], char *const envp[]) {
    REAL(execvpe);
    char found[PATH_MAX];
    note_search(file, found, sizeof found, 1);
    if (found[0])
        note_exec(found);
    int r = real_execvpe(file, argv, envp);
    if (found[0])
        note_exec_failed(found);
    return r;
}

EXPORT int execvp(const char *file, char *const argv[]) {
    REAL(execvp);
    char found[PATH_MAX];
    note_search(file, found, sizeof found, 1);
    if (found[0])
        note_exec(found);
    int r = real_execvp(file, argv);
    if (found[0])
        note_exec_failed(found);
    return r;
}

#define MAX_LIST_ARGS 4096

static int collect_args(const char *first, va_list ap, char **argv, char ***envp) {
    int n = 0;
    argv[n++] = (char *)first;
    while (n < MAX_LIST_ARGS - 1) {
        char *a = va_arg(ap, char *);
        argv[n++] = a;
        if (a == NULL)
            break;
    }
    if (envp)
        *envp = va_arg(ap, char **);
    argv[MAX_LIST_ARGS - 1] = NULL;
    return n;
}

EXPORT int execl(const char *path, const char *arg, ...) {
    char *argv[MAX_LIST_ARGS];
    va_list ap;
    va_start(ap, arg);
    collect_args(arg, ap, argv, NULL);
    va_end(ap);
    return execv(path, argv);
}

EXPORT int execlp(const char *file, const char *arg, ...) {
    char *argv[MAX_LIST_ARGS];
    va_list ap;
    va_start(ap, arg);
    collect_args(arg, ap, argv, NULL);
    va_end(ap);
    return execvp(file, argv);
}

EXPORT int execle(const char *path, const char *arg, ...) {
    char *argv[MAX_LIST_ARGS];
    char **envp = NULL;
    va_list ap;
    va_start(ap, arg);
    collect_args(arg, ap, argv, &envp);
    va_end(ap);
    return execve(path, argv, envp);
}

EXPORT int fexecve(int fd, char *const argv[], char *const envp[]) {
    REAL(fexecve);
    char path[PATH_MAX];
    int known = active && absolute(fd, "", path, sizeof path);
    if (known)
        emit_direct('X', path);
    int r = real_fexecve(fd, argv, envp);
    if (known)
        emit_direct('F', path);
    return r;
}

static void note_spawned(pid_t pid, const char *path) {
    char full[PATH_MAX], line[PATH_MAX + 32];
    if (!active || !absolute(AT_FDCWD, path, full, sizeof full))
        return;
    snprintf(line, sizeof line, "%d %s", (int)pid, full);
    emit('Y', line, 0);
}

EXPORT int posix_spawn(pid_t *pid, const char *path, const posix_spawn_file_actions_t *actions,
                       const posix_spawnattr_t *attr, char *const argv[], char *const envp[]) {
    REAL(posix_spawn);
    pid_t child = 0;
    int r = real_posix_spawn(&child, path, actions, attr, argv, envp);
    if (r == 0)
        note_spawned(child, path);
    if (pid)
        *pid = child;
    return r;
}

EXPORT int posix_spawnp(pid_t *pid, const char *file, const posix_spawn_file_actions_t *actions,
                        const posix_spawnattr_t *attr, char *const argv[], char *const envp[]) {
    REAL(posix_spawnp);
    char found[PATH_MAX];
    note_search(file, found, sizeof found, 0);
    pid_t child = 0;
    int r = real_posix_spawnp(&child, file, actions, attr, argv, envp);
    if (r == 0 && found[0])
        note_spawned(child, found);
    if (pid)
        *pid = child;
    return r;
}

EXPORT void *dlopen(const char *file, int mode) {
    REAL(dlopen);
    void *handle = real_dlopen(file, mode);
    if (handle && active) {
        struct link_map *map = NULL;
        if (dlinfo(handle, RTLD_DI_LINKMAP, &map) == 0 && map && map->l_name &&
            map->l_name[0] == '/')
            emit('R', map->l_name, 1);
        /* and the libraries it needed, which the loader opened on its own (a plugin that is
         * closed before exit takes them out of the maps the destructor reads) */
        dl_iterate_phdr(note_loaded, NULL);
    }
    return handle;
}

/* ------------------------------------------------ what the C library reads on its own */
/* The name service reads /etc/passwd, /etc/group and /etc/nsswitch.conf; the resolver its
 * files; the time functions the time zone (TZ, /etc/localtime): inside the C library, where
 * no wrapper sees the opens. A call to one of them writes down what it reads. */

static void note_users(void) {
    note_if_there("/etc/nsswitch.conf");
    note_if_there("/etc/passwd");
    note_if_there("/etc/group");
}

static void note_hosts(void) {
    note_if_there("/etc/nsswitch.conf");
    note_if_there("/etc/hosts");
    note_if_there("/etc/host.conf");
    note_if_there("/etc/resolv.conf");
    note_if_there("/etc/gai.conf");
}

static void note_zone(void) {
    if (!active)
        return;
    emit('E', "TZ", 1);
    note_if_there("/etc/localtime");
}

#define USERS0(ret, name, params, args) \
    EXPORT ret name params { REAL(name); note_users(); return real_##name args; }

USERS0(struct passwd *, getpwuid, (uid_t uid), (uid))
USERS0(struct passwd *, getpwnam, (const char *n), (n))
USERS0(int, getpwuid_r, (uid_t uid, struct passwd *p, char *b, size_t s, struct passwd **r),
       (uid, p, b, s, r))
USERS0(int, getpwnam_r, (const char *n, struct passwd *p, char *b, size_t s, struct passwd **r),
       (n, p, b, s, r))
USERS0(struct group *, getgrgid, (gid_t gid), (gid))
USERS0(struct group *, getgrnam, (const char *n), (n))
USERS0(int, getgrgid_r, (gid_t gid, struct group *g, char *b, size_t s, struct group **r),
       (gid, g, b, s, r))
USERS0(int, getgrnam_r, (const char *n, struct group *g, char *b, size_t s, struct group **r),
       (n, g, b, s, r))
USERS0(struct passwd *, getpwent, (void), ())
USERS0(struct group *, getgrent, (void), ())
USERS0(int, getgrouplist, (const char *u, gid_t g, gid_t *gs, int *n), (u, g, gs, n))

EXPORT int getaddrinfo(const char *node, const char *service, const struct addrinfo *hints,
                       struct addrinfo **res) {
    REAL(getaddrinfo);
    note_hosts();
    return real_getaddrinfo(node, service, hints, res);
}

EXPORT struct hostent *gethostbyname(const char *name) {
    REAL(gethostbyname);
    note_hosts();
    return real_gethostbyname(name);
}

EXPORT void tzset(void) {
    REAL(tzset);
    note_zone();
    real_tzset();
}

EXPORT struct tm *localtime(const time_t *t) {
    REAL(localtime);
    note_zone();
    return real_localtime(t);
}

EXPORT struct tm *localtime_r(const time_t *t, struct tm *out) {
    REAL(localtime_r);
    note_zone();
    return real_localtime_r(t, out);
}

EXPORT time_t mktime(struct tm *tm) {
    REAL(mktime);
    note_zone();
    return real_mktime(tm);
}

/* ---------------------------------------------------------------------- the environment */

EXPORT char *getenv(const char *name) {
    if (name == NULL)
        return NULL;
    const char *value = env_value(name);
    if (active)
        emit('E', name, 1);
    return (char *)value;
}

EXPORT char *secure_getenv(const char *name) { return getenv(name); }

static const char *const CATEGORY_NAMES[] = {
    [LC_CTYPE] = "LC_CTYPE",       [LC_NUMERIC] = "LC_NUMERIC",
    [LC_TIME] = "LC_TIME",         [LC_COLLATE] = "LC_COLLATE",
    [LC_MONETARY] = "LC_MONETARY", [LC_MESSAGES] = "LC_MESSAGES",
    [LC_PAPER] = "LC_PAPER",       [LC_NAME] = "LC_NAME",
    [LC_ADDRESS] = "LC_ADDRESS",   [LC_TELEPHONE] = "LC_TELEPHONE",
    [LC_MEASUREMENT] = "LC_MEASUREMENT", [LC_IDENTIFICATION] = "LC_IDENTIFICATION",
};

EXPORT char *setlocale(int category, const char *locale) {
    REAL(setlocale);
    if (active && locale != NULL && locale[0] == 0) {
        /* the locale of the environment: LC_ALL, then the category's, then LANG */
        emit('E', "LC_ALL", 1);
        emit('E', "LANG", 1);
        emit('E', "LANGUAGE", 1);
        emit('E', "LOCPATH", 1);
        if (category == LC_ALL) {
            for (size_t i = 0; i < sizeof CATEGORY_NAMES / sizeof *CATEGORY_NAMES; i++)
                if (CATEGORY_NAMES[i])
                    emit('E', CATEGORY_NAMES[i], 1);
        } else if (category >= 0 &&
                   (size_t)category < sizeof CATEGORY_NAMES / sizeof *CATEGORY_NAMES &&
                   CATEGORY_NAMES[category]) {
            emit('E', CATEGORY_NAMES[category], 1);
        }
    }
    char *chosen = real_setlocale(category, locale);
    if (active && chosen != NULL && locale != NULL && locale[0] == 0)
        emit('C', chosen, 1); /* the locale's files are read inside the C library */
    return chosen;
}
