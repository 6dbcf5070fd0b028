// An LD_PRELOAD library for tests/faults/check_sync_order.py: logs, in the order they return, the
// calls that decide what survives a power cut (open, fsync, rename, symlink, mkdir, unlink, rmdir,
// remove: std::filesystem's removals go through it) with the paths they touch, one line each, to
// the file named by GLINT_SYSCALL_LOG. A shim rather than strace, which the build's dependencies
// do not include. Only calls that succeed are logged.
#undef _FORTIFY_SOURCE
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAX_FDS 4096

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
extern "C" {

static int log_fd = -2;              /* -2: not opened yet, -1: no log */
static char* fd_paths[MAX_FDS];      /* what each descriptor was opened on */

static int (*real_open)(const char*, int, ...);
static int (*real_openat)(int, const char*, int, ...);
static int (*real_fsync)(int);
static int (*real_fdatasync)(int);
static int (*real_close)(int);
static int (*real_rename)(const char*, const char*);
static int (*real_renameat)(int, const char*, int, const char*);
static int (*real_symlink)(const char*, const char*);
static int (*real_mkdir)(const char*, mode_t);
static int (*real_unlink)(const char*);
static int (*real_unlinkat)(int, const char*, int);
static int (*real_rmdir)(const char*);
static int (*real_remove)(const char*);

static void resolve(void) {
    if (real_open) return;
    real_open = reinterpret_cast<decltype(real_open)>(dlsym(RTLD_NEXT, "open"));
    real_openat = reinterpret_cast<decltype(real_openat)>(dlsym(RTLD_NEXT, "openat"));
    real_fsync = reinterpret_cast<decltype(real_fsync)>(dlsym(RTLD_NEXT, "fsync"));
    real_fdatasync = reinterpret_cast<decltype(real_fdatasync)>(dlsym(RTLD_NEXT, "fdatasync"));
    real_close = reinterpret_cast<decltype(real_close)>(dlsym(RTLD_NEXT, "close"));
    real_rename = reinterpret_cast<decltype(real_rename)>(dlsym(RTLD_NEXT, "rename"));
    real_renameat = reinterpret_cast<decltype(real_renameat)>(dlsym(RTLD_NEXT, "renameat"));
    real_symlink = reinterpret_cast<decltype(real_symlink)>(dlsym(RTLD_NEXT, "symlink"));
    real_mkdir = reinterpret_cast<decltype(real_mkdir)>(dlsym(RTLD_NEXT, "mkdir"));
    real_unlink = reinterpret_cast<decltype(real_unlink)>(dlsym(RTLD_NEXT, "unlink"));
    real_unlinkat = reinterpret_cast<decltype(real_unlinkat)>(dlsym(RTLD_NEXT, "unlinkat"));
    real_rmdir = reinterpret_cast<decltype(real_rmdir)>(dlsym(RTLD_NEXT, "rmdir"));
    real_remove = reinterpret_cast<decltype(real_remove)>(dlsym(RTLD_NEXT, "remove"));
}

/* dirfd-relative paths as absolute ones (only AT_FDCWD and descriptors this library saw). */
static void full_path(int dirfd, const char* path, char* out, size_t size) {
    if (path[0] == '/') {
        snprintf(out, size, "%s", path);
    } else if (dirfd == AT_FDCWD) {
        char cwd[PATH_MAX];
        snprintf(out, size, "%s/%s", getcwd(cwd, sizeof cwd) ? cwd : "?", path);
    } else {
        snprintf(out, size, "%s/%s", dirfd >= 0 && dirfd < MAX_FDS && fd_paths[dirfd] ? fd_paths[dirfd] : "?", path);
    }
}

static void emit(const char* verb, const char* a, const char* b) {
    if (log_fd == -2) {
        const char* name = getenv("GLINT_SYSCALL_LOG");
        log_fd = name ? real_open(name, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644) : -1;
    }
    if (log_fd < 0) return;
    char line[2 * PATH_MAX + 64];
    const int n = snprintf(line, sizeof line, "%s\t%s%s%s\n", verb, a, b ? "\t" : "", b ? b : "");
    if (n > 0 && write(log_fd, line, static_cast<size_t>(n)) < 0) log_fd = -1;
}

static int opened(int fd, int dirfd, const char* path, int flags) {
    if (fd < 0 || fd >= MAX_FDS) return fd;
    char full[PATH_MAX];
    full_path(dirfd, path, full, sizeof full);
    pthread_mutex_lock(&lock);
    free(fd_paths[fd]);
    fd_paths[fd] = strdup(full);
    if (flags & O_CREAT) emit("create", full, NULL);
    pthread_mutex_unlock(&lock);
    return fd;
}

int open(const char* path, int flags, ...) {
    resolve();
    mode_t mode = 0;
    if (flags & (O_CREAT | O_TMPFILE)) {
        va_list ap;
        va_start(ap, flags);
        mode = static_cast<mode_t>(va_arg(ap, int));
        va_end(ap);
    }
    return opened(real_open(path, flags, mode), AT_FDCWD, path, flags);
}
int open64(const char* path, int flags, ...) __attribute__((alias("open")));

int openat(int dirfd, const char* path, int flags, ...) {
    resolve();
    mode_t mode = 0;
    if (flags & (O_CREAT | O_TMPFILE)) {
        va_list ap;
        va_start(ap, flags);
        mode = static_cast<mode_t>(va_arg(ap, int));
        va_end(ap);
    }
    return opened(real_openat(dirfd, path, flags, mode), dirfd, path, flags);
}
int openat64(int dirfd, const char* path, int flags, ...) __attribute__((alias("openat")));

static int synced(int r, int fd) {
    if (r == 0 && fd >= 0 && fd < MAX_FDS) {
        pthread_mutex_lock(&lock);
        emit("fsync", fd_paths[fd] ? fd_paths[fd] : "?", NULL);
        pthread_mutex_unlock(&lock);
    }
    return r;
}
int fsync(int fd) { resolve(); return synced(real_fsync(fd), fd); }
int fdatasync(int fd) { resolve(); return synced(real_fdatasync(fd), fd); }

int close(int fd) {
    resolve();
    if (fd >= 0 && fd < MAX_FDS) {
        pthread_mutex_lock(&lock);
        free(fd_paths[fd]);
        fd_paths[fd] = NULL;
        pthread_mutex_unlock(&lock);
    }
    return real_close(fd);
}

static int two_paths(int r, const char* verb, int dir_a, const char* a, int dir_b, const char* b) {
    if (r == 0) {
        char fa[PATH_MAX], fb[PATH_MAX];
        full_path(dir_a, a, fa, sizeof fa);
        full_path(dir_b, b, fb, sizeof fb);
        pthread_mutex_lock(&lock);
        emit(verb, fa, fb);
        pthread_mutex_unlock(&lock);
    }
    return r;
}
int rename(const char* a, const char* b) { resolve(); return two_paths(real_rename(a, b), "rename", AT_FDCWD, a, AT_FDCWD, b); }
int renameat(int da, const char* a, int db, const char* b) { resolve(); return two_paths(real_renameat(da, a, db, b), "rename", da, a, db, b); }

int symlink(const char* target, const char* link) {
    resolve();
    const int r = real_symlink(target, link);
    if (r == 0) {
        char fl[PATH_MAX];
        full_path(AT_FDCWD, link, fl, sizeof fl);
        pthread_mutex_lock(&lock);
        emit("symlink", fl, target);
        pthread_mutex_unlock(&lock);
    }
    return r;
}

static int one_path(int r, const char* verb, int dirfd, const char* path) {
    if (r == 0) {
        char full[PATH_MAX];
        full_path(dirfd, path, full, sizeof full);
        pthread_mutex_lock(&lock);
        emit(verb, full, NULL);
        pthread_mutex_unlock(&lock);
    }
    return r;
}
int mkdir(const char* path, mode_t mode) { resolve(); return one_path(real_mkdir(path, mode), "mkdir", AT_FDCWD, path); }
int unlink(const char* path) { resolve(); return one_path(real_unlink(path), "unlink", AT_FDCWD, path); }
int unlinkat(int dirfd, const char* path, int flags) { resolve(); return one_path(real_unlinkat(dirfd, path, flags), "unlink", dirfd, path); }
int rmdir(const char* path) { resolve(); return one_path(real_rmdir(path), "unlink", AT_FDCWD, path); }
int remove(const char* path) { resolve(); return one_path(real_remove(path), "unlink", AT_FDCWD, path); }

}  // extern "C"
