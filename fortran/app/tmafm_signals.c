/* Signal handling of the tmafm executable: a terminating signal (SIGINT, SIGTERM, SIGHUP,
 * SIGQUIT, SIGALRM, SIGUSR1, SIGUSR2, or SIGXCPU at a CPU-time limit) while an output temporary
 * exists removes it, then the process dies of the same signal (the shell sees 128 + signo;
 * SIGQUIT and SIGXCPU still dump core where cores are on).  SIGXFSZ is ignored: a file-size
 * limit is a write error (EFBIG).  SIGPROF and SIGVTALRM are left to profilers.  The one piece
 * of global state, the temporary's name, lives here in the executable, never in the library.
 *
 * Once the output is complete in place (renamed over its name, or written whole to a device,
 * a FIFO or standard output), the run has succeeded: a terminating signal from then on ends the
 * process with exit status 0, and the file stays (docs/reliability.md, Signals).
 *
 * Use: tmafm_signals_install() once; tmafm_signals_hold() before the temporary is created;
 * tmafm_signals_guard(name) right after (this also releases the hold); tmafm_signals_release()
 * once the temporary is gone (removed).  Around the rename: tmafm_signals_hold(), the rename,
 * then tmafm_signals_complete() (the output is in place; this also releases the hold).
 */
#include <signal.h>
#include <stddef.h>
#include <string.h>
#include <unistd.h>

static const int handled[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGALRM, SIGUSR1, SIGUSR2, SIGXCPU};
enum { n_handled = sizeof handled / sizeof handled[0] };

static char guarded_name[16384];
static volatile sig_atomic_t guarded = 0;
static volatile sig_atomic_t completed = 0;

static void on_signal(int signo)
{
    if (completed) _exit(0); /* the output is in place: the run succeeded */
    if (guarded) unlink(guarded_name); /* async-signal-safe */
    signal(signo, SIG_DFL);
    raise(signo); /* delivered on return: the process dies of signo */
}

static void mask_of_handled(sigset_t *set)
{
    sigemptyset(set);
    for (int i = 0; i < n_handled; ++i) sigaddset(set, handled[i]);
}

/* Install the handler for each handled signal that is not ignored (nohup keeps its SIG_IGN).
 * SIGXFSZ (a write past the file-size limit, ulimit -f) is ignored, so that the write fails with
 * EFBIG, an error the writer reports and cleans up after, instead of killing the process with
 * the temporary left behind. */
void tmafm_signals_install(void)
{
    struct sigaction action, previous;
    signal(SIGXFSZ, SIG_IGN);
    memset(&action, 0, sizeof action);
    action.sa_handler = on_signal;
    mask_of_handled(&action.sa_mask);
    for (int i = 0; i < n_handled; ++i) {
        if (sigaction(handled[i], NULL, &previous) == 0 && previous.sa_handler == SIG_IGN) continue;
        sigaction(handled[i], &action, NULL);
    }
}

/* Block the handled signals (so none arrives between creating a file and guarding it). */
void tmafm_signals_hold(void)
{
    sigset_t set;
    mask_of_handled(&set);
    sigprocmask(SIG_BLOCK, &set, NULL);
}

/* Remember `name` (length n) for the handler, then unblock: a pending signal removes it. */
void tmafm_signals_guard(const char *name, size_t n)
{
    sigset_t set;
    if (n < sizeof guarded_name) {
        memcpy(guarded_name, name, n);
        guarded_name[n] = '\0';
        guarded = 1;
    }
    mask_of_handled(&set);
    sigprocmask(SIG_UNBLOCK, &set, NULL);
}

/* The output is complete in place (call with the signals held, right after the rename or the
 * last write): forget the temporary, and from now on a terminating signal exits with status 0;
 * then unblock (a signal that came meanwhile is delivered here, and exits 0). */
void tmafm_signals_complete(void)
{
    sigset_t set;
    guarded = 0;
    completed = 1;
    mask_of_handled(&set);
    sigprocmask(SIG_UNBLOCK, &set, NULL);
}

/* Forget the name (the temporary has been removed) and unblock. */
void tmafm_signals_release(void)
{
    sigset_t set;
    guarded = 0;
    mask_of_handled(&set);
    sigprocmask(SIG_UNBLOCK, &set, NULL);
}
