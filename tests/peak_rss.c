/* peak_rss OUT COMMAND [ARG...]: runs COMMAND and writes "<exit status> <peak resident set in kB>"
 * to OUT (wait4's ru_maxrss of COMMAND alone). tests/memory_test.cpp measures the command's peaks
 * through it: a child forked from the test binary itself starts with the test binary's resident set
 * as its maximum (Linux keeps a process's maxrss across exec, and a forked child starts from its
 * parent's), so a run smaller than the test binary would read as the test binary's size. This
 * program is small, and a child forked from it starts from its small size. */
#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

int main(int argc, char** argv) {
  if (argc < 3) {
    fprintf(stderr, "usage: peak_rss OUT COMMAND [ARG...]\n");
    return 2;
  }
  const pid_t pid = fork();
  if (pid < 0) return 2;
  if (pid == 0) {
    execvp(argv[2], argv + 2);
    _exit(127);
  }
  int st = 0;
  struct rusage ru;
  if (wait4(pid, &st, 0, &ru) != pid) return 2;
  const int code = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  FILE* f = fopen(argv[1], "w");
  if (!f) return 2;
  fprintf(f, "%d %ld\n", code, ru.ru_maxrss);
  return fclose(f) == 0 ? code : 2;
}
