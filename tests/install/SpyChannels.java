// Java agent of the pplvo_spy test (tests/install/test_spy.sh): loaded into the JVM that
// scripts/pplvo-spy starts (JAVA_TOOL_OPTIONS=-javaagent:spy_channels.jar=ARGS), it leaves
// lcm.spy.Spy alone and reads what Spy's window shows: the rows of its channel table.
//
// ARGS: "timeout_s;CHANNEL=type,CHANNEL=type,..." (type as Spy shows it: the class name
// without its package, e.g. pose_t; an unknown fingerprint shows as "?? 0123...").
// Prints SPY_READY once the table is on screen, then, when every expected channel is listed
// with its type, prints "CHANNEL TYPE MESSAGES" per row and exits 0; after timeout_s it prints
// what it has and exits 3.
import java.awt.Component;
import java.awt.Container;
import java.awt.Frame;
import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import javax.swing.JTable;
import javax.swing.SwingUtilities;
import javax.swing.table.TableModel;

public final class SpyChannels {
  private SpyChannels() {}

  public static void premain(String args) {
    Thread t = new Thread(() -> watch(args == null ? "" : args), "pplvo-spy-check");
    t.setDaemon(true);
    t.start();
  }

  private static void watch(String args) {
    String[] parts = args.split(";", 2);
    double timeoutS = parts[0].isEmpty() ? 60.0 : Double.parseDouble(parts[0]);
    Map<String, String> expected = new LinkedHashMap<>();
    if (parts.length > 1) {
      for (String kv : parts[1].split(",")) {
        if (kv.isEmpty())
          continue;
        String[] p = kv.split("=", 2);
        expected.put(p[0], p.length > 1 ? p[1] : "");
      }
    }
    long deadline = System.nanoTime() + (long) (timeoutS * 1e9);
    boolean ready = false;
    List<String[]> rows = new ArrayList<>();
    while (System.nanoTime() < deadline) {
      try {
        Thread.sleep(250);
        List<String[]> now = new ArrayList<>();
        boolean[] found = {false};
        SwingUtilities.invokeAndWait(() -> found[0] = readTable(now));
        if (found[0] && !ready) {
          System.out.println("SPY_READY");
          System.out.flush();
          ready = true;
        }
        rows = now;
        if (found[0] && allListed(rows, expected)) {
          print(rows);
          System.exit(0);
        }
      } catch (Exception e) {
        System.out.println("SPY_ERROR " + e);
      }
    }
    print(rows);
    System.out.println(ready ? "SPY_TIMEOUT" : "SPY_NO_WINDOW");
    System.out.flush();
    Runtime.getRuntime().halt(3);
  }

  private static boolean allListed(List<String[]> rows, Map<String, String> expected) {
    for (Map.Entry<String, String> e : expected.entrySet()) {
      boolean ok = false;
      for (String[] r : rows) ok |= r[0].equals(e.getKey()) && r[1].equals(e.getValue());
      if (!ok)
        return false;
    }
    return true;
  }

  private static void print(List<String[]> rows) {
    for (String[] r : rows) System.out.println("CHANNEL " + r[0] + " " + r[1] + " " + r[2]);
    System.out.flush();
  }

  /** Reads the channel table of Spy's frame; false while it is not shown. */
  private static boolean readTable(List<String[]> out) {
    for (Frame f : Frame.getFrames()) {
      if (!f.isShowing())
        continue;
      JTable table = findTable(f);
      if (table == null)
        continue;
      TableModel m = table.getModel();
      int channel = column(m, "Channel"), type = column(m, "Type"), count = column(m, "Num Msgs");
      if (channel < 0 || type < 0)
        continue;
      for (int r = 0; r < m.getRowCount(); ++r) {
        out.add(new String[] {String.valueOf(m.getValueAt(r, channel)).trim(),
            String.valueOf(m.getValueAt(r, type)).trim(),
            count < 0 ? "?" : String.valueOf(m.getValueAt(r, count)).trim()});
      }
      return true;
    }
    return false;
  }

  private static int column(TableModel m, String name) {
    for (int c = 0; c < m.getColumnCount(); ++c) {
      if (m.getColumnName(c).equalsIgnoreCase(name))
        return c;
    }
    return -1;
  }

  private static JTable findTable(Component c) {
    if (c instanceof JTable)
      return (JTable) c;
    if (c instanceof Container) {
      for (Component child : ((Container) c).getComponents()) {
        JTable t = findTable(child);
        if (t != null)
          return t;
      }
    }
    return null;
  }
}
