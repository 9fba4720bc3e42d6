// Lists which harvest types lcm-spy's own type database (lcm.spy.LCMTypeDatabase,
// built by scanning the classpath exactly as lcm-spy does) can decode.
import java.util.*;
import java.util.jar.*;

public class SpyTypes {
    public static void main(String[] args) throws Exception {
        lcm.spy.LCMTypeDatabase db = new lcm.spy.LCMTypeDatabase();
        List<String> names = new ArrayList<>();
        try (JarFile jar = new JarFile(args[0])) {
            for (Enumeration<JarEntry> e = jar.entries(); e.hasMoreElements();) {
                String n = e.nextElement().getName();
                if (n.startsWith("harvest/") && n.endsWith(".class")) names.add(n.replace('/', '.').replace(".class", ""));
            }
        }
        Collections.sort(names);
        int missing = 0;
        for (String n : names) {
            Class<?> c = Class.forName(n);
            long fp = c.getField("LCM_FINGERPRINT").getLong(null);
            Class<?> found = db.getClassByFingerprint(fp);
            boolean ok = found != null && found.getName().equals(n);
            if (!ok) missing++;
            System.out.println((ok ? "decodes " : "MISSING ") + n);
        }
        System.exit(missing == 0 ? 0 : 1);
    }
}
