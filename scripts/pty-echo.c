/* The floor of a round trip over a pseudo-terminal: the least a server and a client can do per request.
 *
 * Built and run by scripts/pty-bench.sh (cc -O2), beside `tmcl serve` and the Rust client, so that both
 * are measured on the same machine in the same minute (docs/benchmarks.md, "The pty path").
 *
 *   pty-echo serve LINK [poll]   opens a pty in raw mode, points the symlink LINK at its slave side and
 *                                echoes every 9 bytes it reads on the master back, until killed. With
 *                                `poll` it waits in poll() before each read, as a server that also has
 *                                deadlines and other descriptors to watch must.
 *   pty-echo client LINK N       opens LINK raw, as a host opens a serial port, and makes N round trips
 *                                of 9 bytes (write, read until 9 bytes are back), after 100 unmeasured
 *                                ones; prints the median, p90, p99 and max in microseconds.
 *
 * Each request costs the server read + write (poll + read + write with `poll`) and the client write +
 * read, when the 9 bytes travel in one piece (they do on a pty); `strace -c` counts it.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#define FRAME 9

static const char *link_path;

static void remove_link(int sig) {
    (void)sig;
    unlink(link_path);
    _exit(0);
}

static int serve(const char *link, int use_poll) {
    int master, slave;
    char name[256];
    struct termios t;
    if (openpty(&master, &slave, name, NULL, NULL) != 0) {
        perror("openpty");
        return 1;
    }
    tcgetattr(slave, &t);
    cfmakeraw(&t);
    tcsetattr(slave, TCSANOW, &t);
    unlink(link);
    if (symlink(name, link) != 0) {
        perror("symlink");
        return 1;
    }
    link_path = link;
    signal(SIGTERM, remove_link);
    signal(SIGINT, remove_link);
    unsigned char buf[4096];
    size_t have = 0;
    for (;;) {
        if (use_poll) {
            struct pollfd p = {.fd = master, .events = POLLIN};
            if (poll(&p, 1, 1000) < 0 && errno != EINTR) {
                perror("poll");
                return 1;
            }
            if (!(p.revents & POLLIN)) continue;
        }
        ssize_t n = read(master, buf + have, sizeof buf - have);
        if (n < 0) {
            if (errno == EINTR || errno == EAGAIN || errno == EIO) continue;
            perror("read");
            return 1;
        }
        have += (size_t)n;
        size_t whole = have - have % FRAME;
        if (whole) {
            if (write(master, buf, whole) != (ssize_t)whole) {
                perror("write");
                return 1;
            }
            memmove(buf, buf + whole, have - whole);
            have -= whole;
        }
    }
}

static double now_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e6 + ts.tv_nsec / 1e3;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int client(const char *link, long n) {
    int fd = open(link, O_RDWR | O_NOCTTY);
    if (fd < 0) {
        perror(link);
        return 1;
    }
    struct termios t;
    tcgetattr(fd, &t);
    cfmakeraw(&t);
    tcsetattr(fd, TCSANOW, &t);
    tcflush(fd, TCIFLUSH);
    unsigned char req[FRAME] = {1, 6, 1, 0, 0, 0, 0, 0, 8}, rep[FRAME];
    double *samples = malloc(sizeof(double) * (size_t)n);
    for (long i = -100; i < n; i++) {
        double t0 = now_us();
        if (write(fd, req, FRAME) != FRAME) {
            perror("write");
            return 1;
        }
        size_t got = 0;
        while (got < FRAME) {
            ssize_t k = read(fd, rep + got, FRAME - got);
            if (k <= 0) {
                perror("read");
                return 1;
            }
            got += (size_t)k;
        }
        if (i >= 0) samples[i] = now_us() - t0;
    }
    qsort(samples, (size_t)n, sizeof(double), cmp);
    printf("median %.1f µs, p90 %.1f µs, p99 %.1f µs, max %.1f µs (%ld requests)\n", samples[n / 2],
           samples[(long)((n - 1) * 0.9)], samples[(long)((n - 1) * 0.99)], samples[n - 1], n);
    return 0;
}

int main(int argc, char **argv) {
    if (argc >= 3 && strcmp(argv[1], "serve") == 0)
        return serve(argv[2], argc >= 4 && strcmp(argv[3], "poll") == 0);
    if (argc >= 4 && strcmp(argv[1], "client") == 0) return client(argv[2], atol(argv[3]));
    fprintf(stderr, "usage: pty-echo serve LINK [poll] | pty-echo client LINK N\n");
    return 2;
}
