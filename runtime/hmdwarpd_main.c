/* hmdwarpd: entry point (placeholder until the runtime lands). */
#include <stdio.h>
int main(void)
{
    puts("hmdwarpd: not yet");
    return 0;
}
