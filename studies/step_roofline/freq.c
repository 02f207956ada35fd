// Core clock estimate: a chain of dependent register-register adds (x += y) retires one
// a cycle; an add of an immediate can be folded at rename on newer Intel cores.
#include <stdio.h>
#include <time.h>
static double now(void){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec+1e-9*t.tv_nsec;}
int main(void){ double best=1e30; unsigned long x=0, y=1; long n=2000000000L;
 __asm__ volatile("" : "+r"(y));
 for(int r=0;r<5;r++){ double t0=now(); for(long i=0;i<n;i+=8){ __asm__ volatile("add %1,%0\n\tadd %1,%0\n\tadd %1,%0\n\tadd %1,%0\n\tadd %1,%0\n\tadd %1,%0\n\tadd %1,%0\n\tadd %1,%0":"+r"(x):"r"(y)); } double t=now()-t0; if(t<best)best=t;}
 printf("%.3f GHz (dependent register adds; %lu)\n", n/best/1e9, x); return 0; }
