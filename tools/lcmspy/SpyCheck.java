// SpyCheck: decodes every message on the LCM URL for a while the way lcm-spy does (type looked up
// by its fingerprint in the class path's LCM types, then decoded by that class) and prints one line
// per channel. Exit status 1 when a message has an unknown type or does not decode, or when an
// expected channel was not seen.
//
//   java -cp hpr_lcmtypes.jar:lcm.jar:hpr_lcmspy_check.jar hpr.SpyCheck SECONDS [URL [CHANNEL,...]]
//
// With expected channels it listens SECONDS, then on (up to ten times as long) until each has been
// seen: on a loaded machine the JVM may deliver the first seconds' messages late.
package hpr;

import java.io.DataInput;
import java.io.IOException;
import java.util.Map;
import java.util.TreeMap;

import lcm.lcm.LCM;
import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMSubscriber;
import lcm.spy.LCMTypeDatabase;

public class SpyCheck implements LCMSubscriber {
  static class Channel {
    long count, decoded, unknown, failed;
    String type = "?";
    String error = "";
  }

  private final LCMTypeDatabase types = new LCMTypeDatabase();
  private final Map<String, Channel> channels = new TreeMap<>();

  public synchronized void messageReceived(LCM lcm, String channel, LCMDataInputStream ins) {
    Channel c = channels.computeIfAbsent(channel, k -> new Channel());
    c.count++;
    try {
      long fingerprint = ins.readLong();
      ins.reset();
      Class<?> cls = types.getClassByFingerprint(fingerprint);
      if (cls == null) {
        c.unknown++;
        c.error = String.format("no type with fingerprint %016x", fingerprint);
        return;
      }
      c.type = cls.getName();
      cls.getConstructor(DataInput.class).newInstance(ins);
      c.decoded++;
    } catch (IOException | ReflectiveOperationException e) {
      c.failed++;
      c.error = e.toString();
    }
  }

  public static void main(String[] args) throws Exception {
    double seconds = args.length > 0 ? Double.parseDouble(args[0]) : 3.0;
    LCM lcm = args.length > 1 && !args[1].isEmpty() ? new LCM(args[1]) : new LCM();
    String[] expected = args.length > 2 && !args[2].isEmpty() ? args[2].split(",") : new String[0];
    SpyCheck check = new SpyCheck();
    long start = System.nanoTime();
    lcm.subscribe(".*", check);
    Thread.sleep((long) (seconds * 1000));
    while (!check.missing(expected).isEmpty() && System.nanoTime() - start < (long) (10 * seconds * 1e9)) Thread.sleep(100);
    lcm.unsubscribe(".*", check);
    boolean ok = true;
    synchronized (check) {
      System.out.printf("listened %.1f s%n", (System.nanoTime() - start) * 1e-9);
      System.out.printf("%-20s %-34s %8s %8s %8s %8s%n", "CHANNEL", "TYPE", "MESSAGES", "DECODED", "UNKNOWN", "FAILED");
      for (Map.Entry<String, Channel> e : check.channels.entrySet()) {
        Channel c = e.getValue();
        System.out.printf("%-20s %-34s %8d %8d %8d %8d %s%n", e.getKey(), c.type, c.count, c.decoded, c.unknown, c.failed, c.error);
        ok &= c.unknown == 0 && c.failed == 0;
      }
      System.out.println(check.channels.isEmpty() ? "no messages" : ok ? "every message decoded" : "UNDECODABLE messages");
      String missing = check.missing(expected);
      if (!missing.isEmpty()) System.out.println("expected channels not seen: " + missing);
      ok &= missing.isEmpty();
    }
    System.exit(ok && !check.channels.isEmpty() ? 0 : 1);
  }

  /// The expected channels not seen yet, comma separated.
  synchronized String missing(String[] expected) {
    StringBuilder b = new StringBuilder();
    for (String e : expected) {
      if (channels.containsKey(e)) continue;
      if (b.length() > 0) b.append(',');
      b.append(e);
    }
    return b.toString();
  }
}
