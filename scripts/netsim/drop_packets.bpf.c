// tc classifier that drops a fixed share of the packets leaving an interface, at random:
// a lossy link for tests on a kernel without sch_netem. Each IP fragment is a packet here, so
// a datagram larger than the MTU is lost when any of its fragments is.
// Build: clang -O2 -target bpf -DDROP_PER_MILLION=10000 -c drop_packets.bpf.c -o drop.o
// Attach: tc qdisc add dev IF clsact; tc filter add dev IF egress bpf da obj drop.o sec classifier
#include <linux/bpf.h>
#include <linux/pkt_cls.h>

#ifndef DROP_PER_MILLION
#error "define DROP_PER_MILLION (10000 = 1 %)"
#endif

// The helper by its number: no libbpf headers needed.
static unsigned int (*get_prandom_u32)(void) = (void*)BPF_FUNC_get_prandom_u32;

__attribute__((section("classifier"), used)) int drop_packets(struct __sk_buff* skb) {
  (void)skb;
  return get_prandom_u32() % 1000000u < DROP_PER_MILLION ? TC_ACT_SHOT : TC_ACT_OK;
}

char kLicense[] __attribute__((section("license"), used)) = "GPL";
