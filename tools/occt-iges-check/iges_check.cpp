// iges_check: reads an IGES file with OpenCASCADE (OCCT 7.6) and reports, as JSON lines,
// what a real CAD kernel makes of every root entity: whether it transferred, and for each
// face its validity (BRepCheck_Analyzer), area, bounding box, wires and holes, and how it
// classifies query points (BRepClass_FaceClassifier).
//
// Build (one line, against the system OCCT of `apt-get install libocct-data-exchange-dev`):
//   g++ -O1 -std=c++17 -I/usr/include/opencascade tools/occt-iges-check/iges_check.cpp \
//       -o iges_check -lTKIGES -lTKXSBase -lTKBRep -lTKTopAlgo -lTKGeomAlgo -lTKG3d \
//       -lTKG2d -lTKMath -lTKernel
//
// Usage: iges_check FILE.igs [--queries Q.txt] [--area-eps E] [--timeout SECONDS]
//   Q.txt has one query per line, asked of every face:
//     uv U V      U, V in the surface's normalised parameter square [0, 1]^2 (mapped onto
//                 the face's underlying surface bounds); reports IN/OUT/ON and the
//                 surface point S(u, v) that OCCT evaluates there;
//     xyz X Y Z   a 3D point (file units are converted to metres); reports IN/OUT/ON of
//                 its projection onto the face.
//   Blank lines and lines starting with '#' are ignored.
//   --area-eps E: relative error asked of OCCT's adaptive area integration (default
//   1e-9; above 1e-3 OCCT integrates non-adaptively).
//
// Output, one JSON object per line:
//   {"kind":"file",...}          totals: roots, transferred roots, faces, load/transfer
//                                fails and warnings;
//   {"kind":"check",...}         each fail or warning message of loading or transfer,
//                                with the entity's directory entry number (DE);
//   {"kind":"root",...}          each root entity: DE, IGES type and form, label, whether
//                                the transfer failed, how many faces it gave;
//   {"kind":"face",...}          each face of a root: valid, area (m^2), bbox (m), wires,
//                                holes, underlying surface type and parameter bounds, and
//                                the answers to the queries.
// Exit status: 0 when the file was read (whatever the faces are like), 2 when OCCT cannot
// read it, 3 on a bad command line, 4 on timeout.

#include <BRepBndLib.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepClass_FaceClassifier.hxx>
#include <BRepGProp.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <GProp_GProps.hxx>
#include <Geom_Surface.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Reader.hxx>
#include <IGESData_IGESEntity.hxx>
#include <IGESData_IGESModel.hxx>
#include <Interface_Check.hxx>
#include <Interface_CheckIterator.hxx>
#include <Interface_Static.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Standard_Failure.hxx>
#include <TCollection_HAsciiString.hxx>
#include <TopAbs_State.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>
#include <Transfer_TransientProcess.hxx>
#include <XSControl_TransferReader.hxx>
#include <XSControl_WorkSession.hxx>
#include <gp_Pnt.hxx>
#include <gp_Pnt2d.hxx>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

namespace {

struct Query {
  bool uv;
  double a, b, c;
};

std::string json_string(const char* s) {
  std::string out = "\"";
  for (const char* p = s ? s : ""; *p; ++p) {
    unsigned char ch = static_cast<unsigned char>(*p);
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += static_cast<char>(ch);
    } else if (ch < 0x20 || ch >= 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", ch);
      out += buf;
    } else {
      out += static_cast<char>(ch);
    }
  }
  return out + "\"";
}

std::string num(double x) {
  if (!(x == x) || x > 1e300 || x < -1e300) return "null";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

const char* state_name(TopAbs_State s) {
  switch (s) {
    case TopAbs_IN: return "IN";
    case TopAbs_OUT: return "OUT";
    case TopAbs_ON: return "ON";
    default: return "UNKNOWN";
  }
}

void on_alarm(int) {
  const char msg[] = "iges_check: timed out\n";
  ssize_t ignored = write(2, msg, sizeof msg - 1);
  (void)ignored;
  _exit(4);
}

// The directory entry number (DE) of an entity of the model, or 0.
int de_of(const Handle(IGESData_IGESModel) & model, const Handle(Standard_Transient) & ent) {
  int n = model.IsNull() || ent.IsNull() ? 0 : model->Number(ent);
  return n > 0 ? 2 * n - 1 : 0;
}

void print_checks(const char* phase, const Interface_CheckIterator& checks,
                  const Handle(IGESData_IGESModel) & model, int& fails, int& warnings) {
  for (checks.Start(); checks.More(); checks.Next()) {
    const Handle(Interface_Check)& ch = checks.Value();
    int de = checks.Number() > 0 ? 2 * checks.Number() - 1 : 0;
    if (de == 0 && ch->HasEntity()) de = de_of(model, ch->Entity());
    for (int i = 1; i <= ch->NbFails(); ++i, ++fails)
      std::printf("{\"kind\":\"check\",\"phase\":\"%s\",\"de\":%d,\"severity\":\"fail\",\"message\":%s}\n",
                  phase, de, json_string(ch->CFail(i)).c_str());
    for (int i = 1; i <= ch->NbWarnings(); ++i, ++warnings)
      std::printf("{\"kind\":\"check\",\"phase\":\"%s\",\"de\":%d,\"severity\":\"warning\",\"message\":%s}\n",
                  phase, de, json_string(ch->CWarning(i)).c_str());
  }
}

void report_face(int root, int index, const TopoDS_Face& face, const std::vector<Query>& queries,
                 double area_eps) {
  std::ostringstream o;
  o << "{\"kind\":\"face\",\"root\":" << root << ",\"face\":" << index;
  bool valid = false;
  try {
    valid = BRepCheck_Analyzer(face).IsValid();
  } catch (const Standard_Failure& e) {
    o << ",\"check_error\":" << json_string(e.GetMessageString());
  }
  o << ",\"valid\":" << (valid ? "true" : "false");
  GProp_GProps props;
  double area_error = -1.0;
  try {
    area_error = BRepGProp::SurfaceProperties(face, props, area_eps);
    o << ",\"area\":" << num(props.Mass()) << ",\"area_error\":" << num(area_error);
  } catch (const Standard_Failure& e) {
    o << ",\"area\":null,\"area_message\":" << json_string(e.GetMessageString());
  }
  Bnd_Box box;
  BRepBndLib::Add(face, box);
  if (!box.IsVoid()) {
    double x0, y0, z0, x1, y1, z1;
    box.Get(x0, y0, z0, x1, y1, z1);
    o << ",\"bbox\":[" << num(x0) << "," << num(y0) << "," << num(z0) << "," << num(x1) << ","
      << num(y1) << "," << num(z1) << "]";
  }
  int wires = 0;
  for (TopExp_Explorer w(face, TopAbs_WIRE); w.More(); w.Next()) ++wires;
  int edges = 0;
  for (TopExp_Explorer e(face, TopAbs_EDGE); e.More(); e.Next()) ++edges;
  o << ",\"wires\":" << wires << ",\"holes\":" << (wires > 0 ? wires - 1 : 0)
    << ",\"edges\":" << edges;
  Handle(Geom_Surface) surface = BRep_Tool::Surface(face);
  double u0 = 0, u1 = 1, v0 = 0, v1 = 1;
  if (!surface.IsNull()) {
    surface->Bounds(u0, u1, v0, v1);
    o << ",\"surface\":" << json_string(surface->DynamicType()->Name()) << ",\"u_range\":["
      << num(u0) << "," << num(u1) << "],\"v_range\":[" << num(v0) << "," << num(v1) << "]";
  }
  o << ",\"reversed\":" << (face.Orientation() == TopAbs_REVERSED ? "true" : "false");
  o << ",\"tolerance\":" << num(BRep_Tool::Tolerance(face));
  o << ",\"queries\":[";
  double tol = BRep_Tool::Tolerance(face);
  for (size_t k = 0; k < queries.size(); ++k) {
    const Query& q = queries[k];
    if (k) o << ",";
    try {
      if (q.uv) {
        gp_Pnt2d p(u0 + q.a * (u1 - u0), v0 + q.b * (v1 - v0));
        BRepClass_FaceClassifier c(face, p, tol, Standard_True);
        o << "{\"u\":" << num(q.a) << ",\"v\":" << num(q.b) << ",\"state\":\""
          << state_name(c.State()) << "\"";
        if (!surface.IsNull()) {
          gp_Pnt s = surface->Value(p.X(), p.Y());
          o << ",\"p\":[" << num(s.X()) << "," << num(s.Y()) << "," << num(s.Z()) << "]";
        }
        o << "}";
      } else {
        BRepClass_FaceClassifier c(face, gp_Pnt(q.a, q.b, q.c), tol, Standard_True);
        o << "{\"xyz\":[" << num(q.a) << "," << num(q.b) << "," << num(q.c) << "],\"state\":\""
          << state_name(c.State()) << "\"}";
      }
    } catch (const Standard_Failure& e) {
      o << "{\"state\":\"ERROR\",\"message\":" << json_string(e.GetMessageString()) << "}";
    }
  }
  o << "]}";
  std::printf("%s\n", o.str().c_str());
}

}  // namespace

int main(int argc, char** argv) {
  const char* path = nullptr;
  const char* query_path = nullptr;
  unsigned timeout = 120;
  double area_eps = 1e-9;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--queries") && i + 1 < argc) {
      query_path = argv[++i];
    } else if (!std::strcmp(argv[i], "--area-eps") && i + 1 < argc) {
      area_eps = std::strtod(argv[++i], nullptr);
    } else if (!std::strcmp(argv[i], "--timeout") && i + 1 < argc) {
      timeout = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    } else if (argv[i][0] != '-' && !path) {
      path = argv[i];
    } else {
      std::fprintf(stderr, "usage: iges_check FILE.igs [--queries Q.txt] [--area-eps E] [--timeout SECONDS]\n");
      return 3;
    }
  }
  if (!path) {
    std::fprintf(stderr, "usage: iges_check FILE.igs [--queries Q.txt] [--area-eps E] [--timeout SECONDS]\n");
    return 3;
  }
  std::signal(SIGALRM, on_alarm);
  alarm(timeout > 0 ? timeout : 120);

  std::vector<Query> queries;
  if (query_path) {
    std::ifstream in(query_path);
    if (!in) {
      std::fprintf(stderr, "iges_check: cannot open queries %s\n", query_path);
      return 3;
    }
    std::string line;
    int ln = 0;
    while (std::getline(in, line)) {
      ++ln;
      std::istringstream s(line);
      std::string kind;
      if (!(s >> kind) || kind[0] == '#') continue;
      Query q{kind == "uv", 0, 0, 0};
      bool ok = (kind == "uv" && (s >> q.a >> q.b)) || (kind == "xyz" && (s >> q.a >> q.b >> q.c));
      if (!ok) {
        std::fprintf(stderr, "iges_check: %s:%d: expected 'uv U V' or 'xyz X Y Z'\n", query_path, ln);
        return 3;
      }
      queries.push_back(q);
    }
  }

  // OCCT's own progress chatter goes to stdout by default; keep stdout for JSON.
  Message::DefaultMessenger()->RemovePrinters(STANDARD_TYPE(Message_Printer));

  try {
    IGESControl_Reader reader;
    // Report lengths in metres (OCCT converts from the file's unit, global field 14).
    Interface_Static::SetCVal("xstep.cascade.unit", "M");
    if (reader.ReadFile(path) != IFSelect_RetDone) {
      std::fprintf(stderr, "iges_check: OCCT cannot read %s as IGES\n", path);
      return 2;
    }
    Handle(IGESData_IGESModel) model = Handle(IGESData_IGESModel)::DownCast(reader.Model());
    if (model.IsNull() || model->NbEntities() == 0) {
      std::fprintf(stderr, "iges_check: OCCT found no IGES entities in %s\n", path);
      return 2;
    }
    int load_fails = 0, load_warnings = 0, transfer_fails = 0, transfer_warnings = 0;
    print_checks("load", reader.WS()->ModelCheckList(), model, load_fails, load_warnings);

    int roots = reader.NbRootsForTransfer();
    int transferred = 0, faces = 0;
    for (int i = 1; i <= roots; ++i) {
      Handle(IGESData_IGESEntity) ent = Handle(IGESData_IGESEntity)::DownCast(reader.RootForTransfer(i));
      int before = reader.NbShapes();
      bool ok = false;
      std::string error;
      try {
        ok = reader.TransferOneRoot(i) && reader.NbShapes() > before;
      } catch (const Standard_Failure& e) {
        error = e.GetMessageString() ? e.GetMessageString() : "exception";
      }
      TopoDS_Shape shape = ok ? reader.Shape(reader.NbShapes()) : TopoDS_Shape();
      if (ok && shape.IsNull()) ok = false;
      std::vector<TopoDS_Face> root_faces;
      if (ok)
        for (TopExp_Explorer f(shape, TopAbs_FACE); f.More(); f.Next())
          root_faces.push_back(TopoDS::Face(f.Current()));
      std::string label;
      if (!ent.IsNull() && ent->HasShortLabel()) {
        label = ent->ShortLabel()->ToCString();
        label.erase(0, label.find_first_not_of(' '));
      }
      std::printf("{\"kind\":\"root\",\"root\":%d,\"de\":%d,\"type\":%d,\"form\":%d,\"label\":%s,"
                  "\"transfer_failed\":%s,\"faces\":%zu%s%s}\n",
                  i, de_of(model, ent), ent.IsNull() ? 0 : ent->TypeNumber(),
                  ent.IsNull() ? 0 : ent->FormNumber(), json_string(label.c_str()).c_str(),
                  ok && !root_faces.empty() ? "false" : "true", root_faces.size(),
                  error.empty() ? "" : ",\"message\":", error.empty() ? "" : json_string(error.c_str()).c_str());
      std::fflush(stdout);
      if (ok) ++transferred;
      for (size_t k = 0; k < root_faces.size(); ++k) report_face(i, static_cast<int>(k), root_faces[k], queries, area_eps);
      faces += static_cast<int>(root_faces.size());
      std::fflush(stdout);
    }
    Handle(Transfer_TransientProcess) tp = reader.WS()->TransferReader()->TransientProcess();
    if (!tp.IsNull()) print_checks("transfer", tp->CheckList(Standard_False), model, transfer_fails, transfer_warnings);
    std::printf("{\"kind\":\"file\",\"roots\":%d,\"transferred\":%d,\"faces\":%d,\"load_fails\":%d,"
                "\"load_warnings\":%d,\"transfer_fails\":%d,\"transfer_warnings\":%d}\n",
                roots, transferred, faces, load_fails, load_warnings, transfer_fails, transfer_warnings);
  } catch (const Standard_Failure& e) {
    std::fprintf(stderr, "iges_check: OCCT failed on %s: %s\n", path,
                 e.GetMessageString() ? e.GetMessageString() : "exception");
    return 2;
  }
  return 0;
}
