// Decodes C++-encoded harvest messages with the lcm-gen Java classes (the
// ones lcm-spy uses), re-encodes them and prints one line per file:
//   <type> OK <field>=<value> ...   (top-level primitive and string fields)
// or <type> FAIL <reason>.
import java.io.*;
import java.lang.reflect.*;
import java.nio.file.*;
import java.util.*;

public class DecodeCheck {
    public static void main(String[] args) throws Exception {
        File dir = new File(args[0]);
        File[] files = dir.listFiles((d, n) -> n.endsWith(".bin"));
        Arrays.sort(files);
        for (File f : files) {
            String type = f.getName().replace(".bin", "");
            byte[] bytes = Files.readAllBytes(f.toPath());
            try {
                Class<?> c = Class.forName("harvest." + type);
                Object msg = c.getConstructor(byte[].class).newInstance((Object) bytes);
                ByteArrayOutputStream bos = new ByteArrayOutputStream();
                c.getMethod("encode", DataOutput.class).invoke(msg, new DataOutputStream(bos));
                if (!Arrays.equals(bos.toByteArray(), bytes)) {
                    System.out.println(type + " FAIL re-encoded bytes differ");
                    continue;
                }
                StringBuilder sb = new StringBuilder(type + " OK");
                for (Field fld : c.getFields()) {
                    if (Modifier.isStatic(fld.getModifiers())) continue;
                    Class<?> t = fld.getType();
                    if (t.isPrimitive() || t == String.class) sb.append(" ").append(fld.getName()).append("=").append(String.valueOf(fld.get(msg)).replace("\n", "\\n"));
                }
                System.out.println(sb);
            } catch (InvocationTargetException e) {
                System.out.println(type + " FAIL " + e.getCause());
            }
        }
    }
}
